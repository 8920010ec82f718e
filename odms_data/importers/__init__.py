"""Imported data: real segmentations turned into stores by one builder.

An importer reads its source (release.py: the official ODMS release; recording.py: a user's
own recording; synthia.py: SYNTHIA-SEQS video sequences, with its rules in synthia_protocol.py)
into a `MaskPlan` (plan.py). Each is an `Importer` (builder.py): a plan, a way to drop the sources
of bad frames, a check before the commit; the base writes the plan with `write_mask_store`
(mask_store.py), reading the
masks (mask files, mask_files.py, or other mask sources) on worker processes (decoding.py),
recording the oddities the data shows (oddities.py) and reporting progress(label, done, total).
Every importer answers with `ImportResult`s (result.py).
"""
