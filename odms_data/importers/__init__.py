"""Imported data: real segmentations and detections turned into stores through one front door.

An importer reads its source (release.py: the official ODMS release; recording.py: a user's
own recording; synthia.py: SYNTHIA-SEQS video sequences, with its rules in synthia_protocol.py;
odmd.py: ODMD's pickled sets of boxes, read by pickles.py) into a `Plan` of its kind of store
(plan.py: a `MaskPlan` or a `BoxPlan`). Each is an `Importer` (builder.py): a plan, a way to drop
the sources of bad frames, a check before the commit. The base has the store builder
(store/build.py) write the plan, retries without the dropped sources and answers with an
`ImportResult` (result.py). A plan of masks is a store source in mask_store.py, which reads the
masks (mask files, mask_files.py, or other mask sources) on worker processes (decoding.py) and
records the oddities the data shows (mask_store.py); a plan of boxes is store/box_store.py's.
"""
