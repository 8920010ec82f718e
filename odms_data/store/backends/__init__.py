"""The storage backends, Zarr v3 (sharded) and HDF5, behind one small interface.

One module per backend over a common base (common.py): zarr.py, with the direct reader of local
mask shards, and its codecs (zarr_codecs.py); hdf5.py. choose.py says which backend a store is
and opens it; sink.py is the workers' writer of mask shards. Everything else in odms-data reaches
a store's bytes through the names below.
"""

from __future__ import annotations

from .choose import detect_format, open_backend
from .common import HDF5_MAGIC, Backend, Mode, StoreArray
from .hdf5 import Hdf5Backend
from .sink import MaskSink
from .zarr import ShardReader

__all__ = ["HDF5_MAGIC", "Backend", "Hdf5Backend", "MaskSink", "Mode", "ShardReader", "StoreArray",
           "detect_format", "open_backend"]
