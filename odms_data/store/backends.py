"""The two storage backends, Zarr v3 (sharded) and HDF5, behind one small interface.

Both hold the same arrays (format.ARRAYS) and the root attribute `odms`: a JSON object
in Zarr, a JSON string in HDF5 (HDF5 attributes cannot nest).
"""

from __future__ import annotations

import io
import json
from abc import ABC, abstractmethod
from pathlib import Path
from typing import Any, ClassVar, Literal, Protocol

from .. import safe_json
from ..errors import StoreError
from ..urls import is_url, storage_options, url_filesystem
from .format import format_of_name

Mode = Literal["r", "r+", "w"]  # read, update, create
HDF5_MAGIC = b"\x89HDF\r\n\x1a\n"
ZSTD_LEVEL = 3
GZIP_LEVEL = 1


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


class StoreArray(Protocol):
    """An array of an open store: zarr's and h5py's both slice like numpy."""

    @property
    def shape(self) -> tuple[int, ...]: ...

    @property
    def dtype(self) -> Any: ...

    @property
    def chunks(self) -> Any: ...

    def __getitem__(self, key: Any) -> Any: ...

    def __setitem__(self, key: Any, value: Any) -> None: ...


class Backend(ABC):
    """An open store: named arrays that slice like numpy, plus the `odms` attribute."""

    kind: ClassVar[str]
    # True: workers write whole shards of masks into the store themselves; False: they return the
    # compressed chunks and the one writer stores them (`write_raw_chunk`)
    workers_write_shards: ClassVar[bool]
    path: str

    @abstractmethod
    def __init__(self, path: str, mode: Mode) -> None: ...

    @abstractmethod
    def names(self) -> set[str]: ...

    @abstractmethod
    def array(self, name: str) -> StoreArray: ...

    @abstractmethod
    def read_attrs(self) -> dict[str, Any] | None: ...

    @abstractmethod
    def write_attrs(self, attrs: dict[str, Any]) -> None: ...

    @abstractmethod
    def create_array(
        self, name: str, shape: tuple[int, ...], dtype: Any, chunks: tuple[int, ...],
        shards: tuple[int, ...] | None = None,
    ) -> StoreArray: ...

    def write_raw_chunk(self, array: StoreArray, start: int, data: bytes) -> None:
        """Store one already compressed chunk of `array` beginning at row `start` (backends whose
        workers do not write shards)."""
        raise NotImplementedError(f"{self.kind} workers write their shards themselves")

    @abstractmethod
    def check(self) -> None:
        """Raise the error of a write that failed since the store was opened (see _FailSafeFile)."""

    @abstractmethod
    def close(self) -> None: ...


SETTLE_TIMEOUT_S = 60


def settle_zarr_io() -> None:
    """Wait for zarr's writes still in flight on its I/O thread. When one write of a call fails (a
    full disk) or the caller is interrupted, the call raises at once while its other writes go on,
    and would recreate files in a store being removed."""
    import asyncio

    from zarr.core.sync import sync

    async def others() -> None:
        pending = [t for t in asyncio.all_tasks() if t is not asyncio.current_task()]
        if pending:
            await asyncio.wait(pending, timeout=SETTLE_TIMEOUT_S)

    sync(others())


class ZarrBackend(Backend):
    kind = "zarr"
    workers_write_shards = True

    def __init__(self, path: str, mode: Mode) -> None:
        import zarr

        from .zarr_codec import use_bounded_zstd

        use_bounded_zstd()
        self.path = path
        # arrays opened for reading, kept: each opening reads (and checks) its zarr.json, a request
        # or more per array and call on S3
        self._read: dict[str, Any] | None = {} if mode == "r" else None
        # a local store is created in the fresh folder outputs.Partial made, whose marker must stay
        zarr_mode = "a" if mode == "w" and not is_url(path) else mode
        if mode != "w":
            self._check_metadata("")
        try:
            self.group = zarr.open_group(
                store=str(path), mode=zarr_mode, zarr_format=3, storage_options=storage_options(path)
            )
        except OSError:
            if mode == "w":
                raise  # a full disk, say: the writer names the store
            raise StoreError(f"{path}: not a readable Zarr v3 store (cannot be read)") from None
        except Exception as e:  # zarr raises several types for "not a group"
            raise StoreError(f"{path}: not a readable Zarr v3 store ({type(e).__name__}: {e})") from e

    def names(self) -> set[str]:
        try:
            return set(self.group.array_keys())
        except Exception as e:
            raise StoreError(f"{self.path}: cannot list arrays ({type(e).__name__}: {e})") from e

    def _check_metadata(self, name: str) -> None:
        """Bound the size and depth of a zarr.json, local or at a URL, before zarr parses it
        (safe_json.py); zarr reads it again, a small file."""
        if not is_url(self.path):
            meta = Path(self.path) / name / "zarr.json"
            if meta.is_file():
                safe_json.load_file(meta, StoreError)
            return
        url = "/".join([str(self.path).rstrip("/"), *([name] if name else []), "zarr.json"])
        try:
            fs, key = url_filesystem(url)
            raw = fs.cat_file(key, start=0, end=safe_json.MAX_BYTES + 1)
        except FileNotFoundError:
            if not name:  # as open_backend says of a local path
                raise StoreError(f"{self.path}: no such store (no zarr.json there)") from None
            return  # zarr says which array is missing
        except OSError as e:
            raise StoreError(f"{url}: cannot be read ({e.strerror or e})") from None
        safe_json.loads(raw, url, StoreError)

    def array(self, name: str) -> Any:
        if self._read is not None and name in self._read:
            return self._read[name]
        self._check_metadata(name)
        try:
            arr = self.group[name]
        except Exception as e:  # malformed metadata surfaces as many exception types
            raise StoreError(f"{self.path}: array '{name}' is unreadable ({type(e).__name__}: {e})") from e
        if self._read is not None:
            self._read[name] = arr
        return arr

    def read_attrs(self) -> dict[str, Any] | None:
        attrs = self.group.attrs.asdict().get("odms")
        if attrs is not None and not isinstance(attrs, dict):
            raise StoreError(f"{self.path}: attribute 'odms' is not a JSON object")
        return attrs

    def write_attrs(self, attrs: dict[str, Any]) -> None:
        self.group.attrs.update({"odms": attrs})

    def check(self) -> None:
        """Nothing: zarr raises a failed write from the call that made it."""

    def close(self) -> None:
        settle_zarr_io()

    def create_array(self, name, shape, dtype, chunks, shards=None):
        from zarr.codecs import ZstdCodec

        return self.group.create_array(
            name, shape=shape, dtype=dtype, chunks=chunks, shards=shards,
            compressors=ZstdCodec(level=ZSTD_LEVEL, checksum=True), fill_value=0,
            config={"write_empty_chunks": True},  # skipping the per-chunk emptiness scan is 3x faster
        )


class _FailSafeFile(io.FileIO):
    """The file under an HDF5 store being written (h5py's fileobj driver). A write that fails is
    not reported to libhdf5: the error is kept in `failed` and that write and every later one are
    dropped, and the writer raises the error after the call that met it (`Hdf5Backend.check`).

    libhdf5 cannot recover from a failed write: a file whose flush or close failed leaves a file
    id that is freed twice when it is closed again or at exit, a segmentation fault (h5py issues
    914 and 2160). Seeing only successful writes, it closes cleanly; the store is then removed.
    """

    failed: OSError | None = None

    def write(self, b) -> int:
        if self.failed is None:
            try:
                return super().write(b) or 0
            except OSError as e:
                self.failed = e
        return len(memoryview(b))

    def truncate(self, size: int | None = None) -> int:
        if self.failed is None:
            try:
                return super().truncate(size)
            except OSError as e:
                self.failed = e
        return self.tell() if size is None else size


class Hdf5Backend(Backend):
    kind = "hdf5"
    workers_write_shards = False

    def __init__(self, path: str, mode: Mode) -> None:
        import h5py

        self.path, self.mode = path, mode
        self._raw: _FailSafeFile | None = None
        if mode == "w":
            self._raw = _FailSafeFile(path, "w+b")
            try:
                self.file = h5py.File(self._raw, "w")
            except BaseException:
                self._raw.close()
                raise
            return
        try:
            self.file = h5py.File(path, mode)
        except OSError as e:
            raise StoreError(f"{path}: not a readable HDF5 file ({e})") from e

    def names(self) -> set[str]:
        try:
            return set(self.file.keys())
        except Exception as e:
            raise StoreError(f"{self.path}: cannot list arrays ({type(e).__name__}: {e})") from e

    def array(self, name: str) -> Any:
        import h5py

        from .hdf5_reader import BoundedDataset

        try:
            link = self.file.get(name, getlink=True)
            arr = self.file[name] if isinstance(link, h5py.HardLink) else None
        except Exception as e:
            raise StoreError(f"{self.path}: array '{name}' is unreadable ({type(e).__name__}: {e})") from e
        if arr is None:  # resolving a soft or external link would read another object or file
            raise StoreError(f"{self.path}: '{name}' is a {type(link).__name__}, not an array of the file")
        if not isinstance(arr, h5py.Dataset):  # a damaged header can turn it into a group or type
            raise StoreError(f"{self.path}: '{name}' is a {type(arr).__name__}, not an array")
        if self.mode != "r":
            return arr
        try:
            return BoundedDataset(arr)  # reads its creation properties: a damaged header fails here
        except Exception as e:
            raise StoreError(f"{self.path}: array '{name}' is unreadable ({type(e).__name__}: {e})") from e

    def read_attrs(self) -> dict[str, Any] | None:
        try:
            raw = self.file.attrs.get("odms")
        except Exception as e:  # a damaged object header surfaces as KeyError, OSError, ...
            raise StoreError(f"{self.path}: attributes are unreadable ({type(e).__name__}: {e})") from e
        if raw is None:
            return None
        if not isinstance(raw, str | bytes):
            raise StoreError(f"{self.path}: attribute 'odms' is not a JSON string")
        attrs = safe_json.loads(raw, f"{self.path}: attribute 'odms'", StoreError)
        if not isinstance(attrs, dict):
            raise StoreError(f"{self.path}: attribute 'odms' is not a JSON object")
        return attrs

    def write_attrs(self, attrs: dict[str, Any]) -> None:
        self.file.attrs["odms"] = json.dumps(attrs)

    def create_array(self, name, shape, dtype, chunks, shards=None):
        chunks = tuple(max(1, min(c, s)) for c, s in zip(chunks, shape, strict=True))
        return self.file.create_dataset(
            name, shape=shape, dtype=dtype, chunks=chunks, compression="gzip",
            compression_opts=GZIP_LEVEL, fillvalue=0,
        )

    def write_raw_chunk(self, array: StoreArray, start: int, data: bytes) -> None:
        array.id.write_direct_chunk((start, *(0,) * (len(array.shape) - 1)), data)  # type: ignore[attr-defined]

    def check(self) -> None:
        if self._raw is not None and self._raw.failed is not None:
            raise self._raw.failed

    def close(self) -> None:
        try:
            self.file.close()
        finally:
            if self._raw is not None:
                self._raw.close()
        self.check()


def open_backend(path: str, mode: Mode = "r", fmt: str | None = None) -> Backend:
    """Open the store at `path`; `fmt` defaults to what `detect_format` finds."""
    fmt = fmt or detect_format(path)
    local = Path(path) if not is_url(path) else None
    if mode != "w" and local is not None:
        if not local.exists():
            raise StoreError(f"{path}: no such store")
        if local.is_file() and fmt == "zarr":  # a file without the HDF5 signature
            what = ("not an HDF5 file (it lacks the HDF5 signature)" if format_of_name(local) == "hdf5"
                    else "not a store (an odms-data store is a Zarr folder or an HDF5 file)")
            raise StoreError(f"{path}: {what}")
        if local.is_dir() and not (local / "zarr.json").exists():
            raise StoreError(f"{path}: not a Zarr v3 store (the folder has no zarr.json)")
    return BACKENDS["zarr" if fmt == "zarr" else "hdf5"](str(path), mode)


BACKENDS: dict[str, type[Backend]] = {"zarr": ZarrBackend, "hdf5": Hdf5Backend}

