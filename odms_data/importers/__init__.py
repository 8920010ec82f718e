"""Imported data: real segmentations turned into stores by one builder.

An importer reads its source (release.py: the official ODMS release; recording.py: a user's
own recording; synthia.py: SYNTHIA-SEQS video sequences, with its rules in synthia_protocol.py)
into a `Plan` (plan.py); `build_store` (builder.py) writes it, reading the masks (mask files,
mask_files.py, or other mask sources) on worker processes (decoding.py) and recording the
oddities the data shows (oddities.py).
"""
