"""Which backend a store is, from what is at its path or from its name, and opening it."""

from __future__ import annotations

from pathlib import Path

from ...errors import StoreError
from ...urls import is_url
from ..format import format_of_name
from .common import HDF5_MAGIC, Backend, Mode
from .hdf5 import Hdf5Backend
from .zarr import ZarrBackend


def detect_format(path: str) -> str:
    """'zarr' or 'hdf5', from what is at `path` or, for a new store, from its suffix."""
    p = str(path)
    if is_url(p):
        return "zarr"
    local = Path(p)
    if local.is_file():
        with open(local, "rb") as f:
            return "hdf5" if f.read(8) == HDF5_MAGIC else "zarr"
    return format_of_name(local) or "zarr"



def open_backend(path: str, mode: Mode = "r", fmt: str | None = None) -> Backend:
    """Open the store at `path`; `fmt` defaults to what `detect_format` finds."""
    fmt = fmt or detect_format(path)
    local = Path(path) if not is_url(path) else None
    if mode != "w" and local is not None:
        if not local.exists():
            raise StoreError(f"{path}: no such store")
        if not local.is_file() and not local.is_dir():  # h5py would wait on a FIFO forever
            raise StoreError(f"{path}: not a store (a FIFO, device or socket, not a file or folder)")
        if local.is_file() and fmt == "zarr":  # a file without the HDF5 signature
            what = ("not an HDF5 file (it lacks the HDF5 signature)" if format_of_name(local) == "hdf5"
                    else "not a store (an odms-data store is a Zarr folder or an HDF5 file)")
            raise StoreError(f"{path}: {what}")
        if local.is_dir() and not (local / "zarr.json").exists():
            raise StoreError(f"{path}: not a Zarr v3 store (the folder has no zarr.json)")
    return BACKENDS["zarr" if fmt == "zarr" else "hdf5"](str(path), mode)


BACKENDS: dict[str, type[Backend]] = {"zarr": ZarrBackend, "hdf5": Hdf5Backend}

