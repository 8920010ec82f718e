"""What a store declares against what it holds, checked before a reader allocates anything.

A store may come from a stranger, and its metadata says how much a reader will allocate: the
arrays' shapes and chunk shapes. Before anything is read (`storage_problems`):

- every array is a plain array, stored as odms-data writes them: HDF5 datasets that are hard
  links, neither virtual nor external, chunked, gzip or no filter; Zarr arrays whose codecs are
  the ones odms-data writes (each decoded with a bound, backends/common.py);
- a chunk decodes to at most MAX_CHUNK_BYTES, the most one read holds;
- every chunk is there: a store is always written whole, so an absent chunk is damage, never
  zeros;
- the arrays read whole (all but `masks`) declare at most max(FREE_BYTES, MAX_RATIO x the bytes
  the store holds on disk): a 100 KB store cannot make a reader allocate gigabytes.
"""

from __future__ import annotations

import math
import os
from collections.abc import Iterable
from pathlib import Path
from typing import Any

import numpy as np

from ..urls import is_url, url_filesystem
from .backends import Backend
from .backends.hdf5 import DEFLATE
from .format import arrays_of, kind_of, layout_problems

MAX_CHUNK_BYTES = 64 * 2**20  # a mask chunk of the largest images odms-data makes is under 2 MB
FREE_BYTES = 64 * 2**20  # small stores are never refused by MAX_RATIO
# decoded bytes of the arrays read whole, per byte on disk: a frame costs 40 of them, and its
# z alone (strictly increasing floats) takes several bytes compressed, its mask more
MAX_RATIO = 64
ZARR_CODECS = {"bytes", "zstd", "sharding_indexed", "crc32c"}
WHOLE = "masks"  # the one array read in slices; every other is read whole and cached


def store_problems(backend: Backend, raw: dict[str, Any]) -> list[str]:
    """What the readers check before reading an open store: the layout its attributes `raw`
    promise (format.layout_problems), then the storage rules above, one line each."""
    return layout_problems(backend, raw) or storage_problems(backend, list(arrays_of(kind_of(raw))))


def storage_problems(backend: Backend, names: Iterable[str]) -> list[str]:
    """Every way the arrays `names` of an open store break the rules above, one line each."""
    arrays = {name: backend.array(name) for name in names}
    check = _hdf5_problems if backend.format == "hdf5" else _zarr_problems
    return _size_problems(backend, arrays) or [
        p for name, arr in arrays.items() for p in check(backend, name, arr)
    ]


def _chunk_problems(name: str, arr: Any, chunks: tuple[int, ...]) -> list[str]:
    nbytes = math.prod(chunks) * np.dtype(arr.dtype).itemsize
    if nbytes > MAX_CHUNK_BYTES:
        return [f"array '{name}' has chunks of {nbytes} bytes, more than the {MAX_CHUNK_BYTES} "
                "odms-data reads"]
    return []


def _grid(shape: tuple[int, ...], chunks: tuple[int, ...]) -> tuple[int, ...]:
    return tuple(-(-s // c) for s, c in zip(shape, chunks, strict=True))


def _size_problems(backend: Backend, arrays: dict[str, Any]) -> list[str]:
    declared = sum(math.prod(arr.shape) * np.dtype(arr.dtype).itemsize
                   for name, arr in arrays.items() if name != WHOLE)
    if declared <= FREE_BYTES:
        return []
    on_disk = _bytes_on_disk(backend.path)
    if declared > MAX_RATIO * on_disk:
        return [f"its arrays declare {declared} bytes, more than {MAX_RATIO} times the {on_disk} bytes "
                "it holds (damaged or forged shapes)"]
    return []


def _bytes_on_disk(path: str) -> int:
    if is_url(path):
        fs, root = url_filesystem(path)
        return int(fs.du(root))
    local = Path(path)
    if local.is_file():
        return local.stat().st_size
    return sum(os.path.getsize(os.path.join(d, f)) for d, _, files in os.walk(local) for f in files)


# --- HDF5 -------------------------------------------------------------------------------------
def _hdf5_problems(backend: Any, name: str, arr: Any) -> list[str]:
    try:
        return _hdf5_layout_problems(name, arr)
    except Exception as e:  # libhdf5 on damaged metadata (a chunk B-tree): RuntimeError, OSError, ...
        return [f"dataset '{name}' is unreadable ({type(e).__name__}: {e})"]


def _hdf5_layout_problems(name: str, arr: Any) -> list[str]:
    dset = arr.dset  # a BoundedDataset's; Hdf5Backend.array refuses links
    if dset.is_virtual or dset.external:
        return [f"'{name}' is a {'virtual' if dset.is_virtual else 'external'} dataset, "
                "not one stored in the file"]
    filters = set(arr.filters)
    if filters - {DEFLATE}:
        return [f"dataset '{name}' uses HDF5 filter(s) {sorted(filters - {DEFLATE})}, which odms-data "
                "does not write"]
    if dset.chunks is None:
        return [f"dataset '{name}' is not chunked, as odms-data writes it"]
    problems = _chunk_problems(name, dset, dset.chunks)
    expected = math.prod(_grid(dset.shape, dset.chunks))
    stored = dset.id.get_num_chunks()
    if stored != expected:
        problems.append(f"dataset '{name}' holds {stored} of its {expected} chunks (a damaged store)")
    return problems


# --- Zarr -------------------------------------------------------------------------------------
def _zarr_problems(backend: Any, name: str, arr: Any) -> list[str]:
    codecs = _codec_names(arr.metadata.codecs)
    if codecs - ZARR_CODECS:
        return [f"array '{name}' uses codec(s) {', '.join(sorted(codecs - ZARR_CODECS))}, which "
                "odms-data does not write"]
    grid_chunks = tuple(arr.metadata.chunk_grid.chunk_shape)  # the shards, where sharded
    chunks = tuple(arr.chunks)
    empty = next((c for c in (grid_chunks, chunks) if min(c, default=1) < 1), None)
    if empty is not None:  # zarr opens it; the grid below divides by it
        return [f"array '{name}' declares chunks of shape {empty}, with an empty side (a damaged store)"]
    problems = _chunk_problems(name, arr, chunks)
    index_bytes = 16 * math.prod(_grid(grid_chunks, chunks))
    if index_bytes > MAX_CHUNK_BYTES:
        problems.append(f"array '{name}' has shard indexes of {index_bytes} bytes, more than the "
                        f"{MAX_CHUNK_BYTES} odms-data reads")
    missing = _missing_chunk(backend, name, arr, _grid(arr.shape, grid_chunks))
    if missing is not None:
        problems.append(f"array '{name}' lacks chunk {missing} (a damaged store)")
    return problems


def _codec_names(codecs: Iterable[Any]) -> set[str]:
    """The names of `codecs` and of the codecs inside them (a sharding codec's)."""
    out = set()
    for c in codecs:
        out.add(c.to_dict()["name"])
        out |= _codec_names(getattr(c, "codecs", ())) | _codec_names(getattr(c, "index_codecs", ()))
    return out


def _missing_chunk(backend: Any, name: str, arr: Any, grid: tuple[int, ...]) -> str | None:
    """The key of a chunk (or shard) of the array's grid that is not stored, or None."""
    stored = _stored_keys(backend.path, name)
    for cell in np.ndindex(*grid):  # the first absent one comes within len(stored) + 1 cells
        key = arr.metadata.encode_chunk_key(tuple(int(i) for i in cell))
        if key not in stored:
            return key
    return None


def _stored_keys(path: str, name: str) -> set[str]:
    """The chunk keys stored for array `name` ('c/0/1', ...)."""
    if is_url(path):
        fs, root = url_filesystem(path)
        base = f"{root.rstrip('/')}/{name}/"
        return {f[len(base):] for f in fs.find(base) if not f.endswith("zarr.json")}
    folder = Path(path) / name
    return {str(Path(d, f).relative_to(folder)).replace(os.sep, "/")
            for d, _, files in os.walk(folder) for f in files if f != "zarr.json"}
