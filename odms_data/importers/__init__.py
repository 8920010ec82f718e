"""Imported data: real segmentations and detections turned into stores through one front door.

An importer reads its source (release.py: the official ODMS release; recording.py: a user's
own recording; synthia.py: SYNTHIA-SEQS video sequences, with its rules in synthia_protocol.py;
odmd.py: ODMD's pickled sets of boxes, read by pickles.py) into a `Plan` of its kind of store
(plan.py: a `MaskPlan` or a `BoxPlan`). Each is an `Importer` (builder.py): a plan, a way to drop
the sources of bad frames, a check before the commit. The base writes the plan, reports
progress(label, done, total), retries without the dropped sources and answers with an
`ImportResult` (result.py). A store of masks is written by `write_mask_store` (mask_store.py),
reading the masks (mask files, mask_files.py, or other mask sources) on worker processes
(decoding.py) and recording the oddities the data shows (oddities.py); a store of boxes by
store/box_store.py.
"""
