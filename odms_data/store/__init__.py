"""The store format: how ODMS examples are kept on disk (schemas/FORMAT.md).

Arrays and attributes (format.py), bit-packed masks and their statistics (masks.py), the content
digest (digest.py), the Zarr and HDF5 backends with their codecs, the fast reader of local Zarr
shards and the workers' shard writer (backends/), the store builder, the only code that writes a
store (build.py), with the atomic writer it drives (writer.py), the reader, `open_store`
(reader.py), validation (validate.py), Zarr <-> HDF5 conversion (convert.py) and a store of known
rows of boxes (box_store.py), both store sources, ODMD's box rule (box_rule.py), the split
manifests of splits/ (manifests.py).
Everything above this layer reads stores through these modules and writes them through build.py;
nothing here knows where examples come from.
"""
