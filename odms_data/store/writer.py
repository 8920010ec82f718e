"""Writing a store atomically: into `<path>.partial` under a lock, moved into place at commit.

A store is complete only when its `odms` attribute says `complete: true`, which `commit` writes
last; for local paths the finished store is also flushed to disk and renamed into place, so an
interrupted write leaves at most a `.partial` sibling that the next run removes. Stores at URLs
(no rename) rely on the attribute alone. The rules are those of every output, which outputs.py
owns; this module only says what a store is (`STORE`): an existing path is refused unless
`overwrite`, and even then only an odms-data store or an empty folder is replaced.
"""

from __future__ import annotations

import os
from contextlib import ExitStack
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from .. import safe_json
from ..errors import InputError, OdmsError, StoreError, StoreExistsError, StoreLockedError
from ..interrupts import uninterrupted
from ..outputs import (
    DISK_FULL,
    OutputType,
    Partial,
    check_replaceable,
    output_lock,
    refuse_existing,
    write_error,
)
from ..urls import is_url, reaching, url_filesystem
from .backends import HDF5_MAGIC, Backend, MaskSink, detect_format, open_backend
from .format import (
    ARRAYS,
    ATTRS_KEY,
    KINDS,
    StoreAttrs,
    arrays_of,
    arrays_per,
    encode_strings,
    format_of_name,
    shape_of,
)
from .masks import packed_width


@dataclass(frozen=True)
class Layout:
    """Shapes and chunking of a new store."""

    height: int
    width: int
    n_frames: int
    n_examples: int
    max_obs: int  # columns of frame_index
    id_width: int
    source_width: int
    frames_per_chunk: int  # frames per compressed mask chunk
    frames_per_shard: int  # frames per shard (and per chunk of the per-frame arrays)
    examples_per_chunk: int  # rows per chunk of the per-example arrays
    kind: str = "masks"  # what the examples are made of (format.KINDS)

    def __post_init__(self) -> None:
        if self.n_frames < 1 or self.n_examples < 1:
            raise InputError("a store needs at least one example and one frame")
        if self.kind not in KINDS:
            raise InputError(f"a store holds one of {', '.join(KINDS)}, not {self.kind!r}")
        if self.frames_per_shard % self.frames_per_chunk:
            raise InputError("frames_per_shard must be a multiple of frames_per_chunk")

    @property
    def sizes(self) -> dict[str, int]:
        """The sizes the array table names (format.py)."""
        return {"height": self.height, "packed_width": packed_width(self.width), "max_obs": self.max_obs,
                "id_width": self.id_width, "source_width": self.source_width}


def _not_a_store(path: Path) -> str | None:
    """What is at `path` when it is neither an odms-data store nor an empty folder, else None
    (outputs.check_replaceable refuses a symbolic link before asking)."""
    if path.is_dir():
        entries = sorted(p.name for p in path.iterdir())
        if not entries:
            return None
        try:
            meta = safe_json.load_file(path / "zarr.json")
            ours = isinstance(meta.get("attributes", {}).get(ATTRS_KEY), dict)
        except (OdmsError, AttributeError):
            ours = False
        if not ours:
            return (f"is a folder of {len(entries)} entr{'y' if len(entries) == 1 else 'ies'} that is not "
                    f"an odms-data store (e.g. {entries[0]!r})")
        others = [e for e in entries if e not in {"zarr.json", *ARRAYS}]
        if others:
            return f"is an odms-data store that also holds {others[0]!r}"
        return None
    if not path.is_file():  # opening a FIFO would wait for a writer forever
        return "is a FIFO, device or socket, not an odms-data store"
    try:
        with open(path, "rb") as f:
            if f.read(8) == HDF5_MAGIC:
                import h5py

                with h5py.File(path, "r") as h:
                    if ATTRS_KEY in h.attrs:
                        return None
    except OSError:
        pass
    return "is a file that is not an odms-data store"


STORE = OutputType("store", _not_a_store, StoreExistsError, StoreLockedError)


def _check_suffix(path: str, fmt: str) -> None:
    """Refuse a format that contradicts the output's name (a Zarr store called x.h5)."""
    if is_url(path):
        if fmt == "hdf5":
            raise InputError(f"{path}: HDF5 stores are local files; write a Zarr store to a URL")
        return
    suffix, named = Path(path).suffix.lower(), format_of_name(path)
    if fmt == "zarr" and named == "hdf5":
        raise InputError(f"{path}: the name says HDF5 ({suffix}) but the format asked for is zarr",
                         fix="name-zarr")
    if fmt == "hdf5" and named == "zarr":
        raise InputError(f"{path}: the name says Zarr (.zarr) but the format asked for is hdf5",
                         fix="name-hdf5")


class StoreWriter:
    """Context manager that creates a store; call `create`, the `write_*` methods, then `commit`."""

    def __init__(self, path: str, fmt: str | None = None, *, overwrite: bool = False) -> None:
        self.path = str(path)
        if fmt is not None:
            _check_suffix(self.path, fmt)
        self.format = fmt or detect_format(self.path)
        self.overwrite = overwrite
        self.local = not is_url(self.path)
        self._partial = (Partial(self.path, folder=self.format == "zarr", output_type=STORE)
                         if self.local else None)
        self.partial = str(self._partial.path) if self._partial else self.path
        self.backend: Backend | None = None
        self.arrays: dict = {}
        self.layout: Layout | None = None
        self._held = ExitStack()
        self._committed = False
        self._attrs: StoreAttrs | None = None

    # --- lifetime ----------------------------------------------------------------------
    def __enter__(self) -> StoreWriter:
        if not self.local:
            _check_new_url_store(self.path, self.overwrite)
            return self
        partial: Partial = self._partial  # type: ignore[assignment]  # local
        try:  # into `_held` at once: a stop anywhere in here releases what was taken so far
            self._held.enter_context(output_lock(self.path, STORE))
            check_replaceable(self.path, self.overwrite, STORE)
            self._held.callback(partial.discard)  # set before it is made: a stop in between leaves nothing
            try:
                partial.make()
            except OSError as e:
                raise write_error(self.path, e) from None
        except BaseException:
            self._held.close()
            raise
        return self

    def __exit__(self, exc_type, exc, tb) -> None:
        with self._held:  # the partial store is discarded (a no-op once committed), the lock released
            if not self._committed and self.backend is not None:
                try:
                    self.backend.close()
                except Exception:
                    if exc is None:
                        raise
        where = str(self._partial.folder) if self._partial else self.path
        if isinstance(exc, OSError) and (exc.errno in DISK_FULL or _inside(exc.filename, where)):
            raise write_error(self.path, exc) from exc

    # --- content -----------------------------------------------------------------------
    def create(self, layout: Layout) -> None:
        """Create every array of the store with the given shapes and chunking."""
        with uninterrupted():
            self.layout = L = layout
            self.backend = b = open_backend(self.partial, "w", self.format)
            rows = {"frame": L.n_frames, "example": L.n_examples}
            per_chunk = {"frame": L.frames_per_shard, "example": L.examples_per_chunk}
            for a in arrays_of(L.kind).values():
                shape = shape_of(a, rows[a.per], L.sizes)
                chunks = (per_chunk[a.per], *shape[1:])
                if a.sharded:
                    self.arrays[a.name] = b.create_array(
                        a.name, shape, a.dtype, (L.frames_per_chunk, *shape[1:]), shards=chunks
                    )
                else:
                    self.arrays[a.name] = b.create_array(a.name, shape, a.dtype, chunks)

    def _created(self) -> tuple[Backend, Layout]:
        if self.backend is None or self.layout is None:
            raise StoreError(f"{self.path}: the store's arrays are written before create() was called")
        return self.backend, self.layout

    def write_masks(self, start: int, packed: np.ndarray) -> None:
        with uninterrupted():
            self.arrays["masks"][start : start + len(packed)] = packed
            self._created()[0].check()

    def mask_sink(self) -> MaskSink:
        """Where workers write the masks (picklable; local paths absolute: workers may have another cwd)."""
        _, L = self._created()
        return MaskSink(os.path.abspath(self.partial) if self.local else self.partial, self.format,
                        L.frames_per_chunk)

    def receive_masks(self, start: int, returned: list[bytes]) -> None:
        """Store what a worker's `MaskSink.write` returned for its shard beginning at frame `start`."""
        with uninterrupted():
            backend, L = self._created()
            for c, chunk in enumerate(returned):
                backend.write_raw_chunk(self.arrays["masks"], start + c * L.frames_per_chunk, chunk)
            backend.check()

    def write_rows(self, per: str, start: int, columns: dict[str, Any]) -> None:
        """Rows from `start` of every array per frame or per example (`per`) but the sharded masks,
        by name: a text array as a list of strings, a narrower matrix padded with the array's `pad`."""
        with uninterrupted():
            _, L = self._created()
            names = [a.name for a in arrays_per(per, L.kind) if not a.sharded]
            if sorted(columns) != sorted(names):
                raise StoreError(f"{self.path}: the {per} arrays are {', '.join(names)}, "
                                 f"not {', '.join(columns)}")
            for name, values in columns.items():
                a, arr = ARRAYS[name], self.arrays[name]
                width = arr.shape[1:]
                if a.text:
                    values = _fit(encode_strings(values), width[0], name.replace("_", " "))
                elif width and np.shape(values)[1:] != width:
                    padded = np.full((len(values), *width), a.pad, a.dtype)
                    padded[:, : np.shape(values)[1]] = values
                    values = padded
                arr[start : start + len(values)] = values
            self._created()[0].check()

    def finish(self, attrs: StoreAttrs) -> None:
        """Write the attributes and close the store, not yet committed: complete where the commit
        is a rename (locally), at a URL once committed."""
        with uninterrupted():
            backend, L = self._created()
            if attrs.kind != L.kind:
                raise StoreError(f"{self.path}: a store created for {L.kind} is committed as {attrs.kind}")
            attrs.complete = True
            raw = attrs.to_json()
            raw["complete"] = self.local
            backend.write_attrs(raw)
            backend.close()
            self._attrs = attrs

    def commit(self, attrs: StoreAttrs | None = None) -> str:
        """Mark the store complete (`finish`, unless given no attributes after it) and move it into
        place; returns its path."""
        if attrs is not None:
            self.finish(attrs)
        with uninterrupted():
            backend, _ = self._created()
            if self._partial is not None:
                check_replaceable(self.path, self.overwrite, STORE)  # again: something may have come
                self._partial.commit()
            elif self._attrs is not None:
                backend.write_attrs(self._attrs.to_json())
                backend.close()
            self._committed = True
            return self.path


def _inside(filename: object, folder: str) -> bool:
    return isinstance(filename, str) and (filename == folder or filename.startswith(folder + os.sep))


def _check_new_url_store(url: str, overwrite: bool) -> None:
    """`outputs.check_replaceable` for a URL: what is there is read with fsspec."""
    try:
        fs, root = url_filesystem(url)
    except ImportError as e:
        raise InputError(f"{url}: writing to a URL needs fsspec and the package of its protocol "
                         f"({e}); see docs/DISTRIBUTED.md") from None
    except ValueError as e:
        raise InputError(f"{url}: not a URL odms-data can write to ({e})") from None

    def foreign() -> str | None:
        entries = fs.ls(root, detail=False)
        if not entries:
            return None
        try:
            meta = safe_json.loads(fs.cat_file(f"{root.rstrip('/')}/zarr.json"), url)
            ours = isinstance(meta.get("attributes", {}).get(ATTRS_KEY), dict)
        except (OSError, OdmsError, AttributeError):
            ours = False
        return None if ours else f"holds {len(entries)} entries that are not an odms-data store"

    with reaching(url):
        refuse_existing(url, fs.exists(root), overwrite, foreign, STORE)


def _fit(matrix: np.ndarray, width: int, what: str) -> np.ndarray:
    if matrix.shape[1] > width:
        raise InputError(f"{what} longer than {width} bytes")
    out = np.zeros((len(matrix), width), np.uint8)
    out[:, : matrix.shape[1]] = matrix
    return out
