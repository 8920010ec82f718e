"""The store format: how ODMS examples are kept on disk (schemas/FORMAT.md).

Arrays and attributes (format.py), bit-packed masks and their statistics (masks.py), the content
digest (digest.py), the Zarr and HDF5 backends with their codecs, the fast reader of local Zarr
shards and the workers' shard writer (backends/), the atomic writer (writer.py), the reader,
`open_store` (reader.py), validation (validate.py), Zarr <-> HDF5 conversion (convert.py), the
split manifests of splits/ (manifests.py). Everything above this layer reads and writes stores
through these modules; nothing here knows where examples come from.
"""
