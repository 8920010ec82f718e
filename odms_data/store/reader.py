"""Reading a store: `open_store(path)` and the `Store` and `Example` it gives."""

from __future__ import annotations

import difflib
import re
from dataclasses import dataclass
from functools import cached_property
from typing import Any, TypeVar

import numpy as np

from ..errors import InputError, StoreError
from .backends import Backend, ShardReader, open_backend
from .declared import store_problems
from .format import (
    StoreAttrs,
    arrays_of,
    box_problems,
    d1_problems,
    decode_strings,
    depth_problems,
    frame_index_problems,
    id_problems,
    kind_of,
    stats_problems,
    z_problems,
)
from .masks import packed_width, unpack

T = TypeVar("T")
_CHECKED = {"example_id": "example_ids", "source": "sources"}  # the Store attributes of text arrays


_NUMBERED = re.compile(r"(.*)/(\d+)")  # an example id ending in its number: split/000042


@dataclass
class Example:
    """One example: n masks (or, from a store of boxes, n boxes) with their camera positions,
    depths and label."""

    example_id: str
    source: str
    d1: float  # NaN when unlabelled
    frames: np.ndarray  # (n,) frame rows in the store
    z: np.ndarray  # (n,) m, ascending
    depth: np.ndarray  # (n,) m, NaN where unknown
    masks: np.ndarray  # (n, H, W) bool; (0, H, W) from a store of boxes
    boxes: np.ndarray | None = None  # (n, 4) [x_c, y_c, w, h] normalised: a store of boxes only

    @property
    def n(self) -> int:
        return len(self.frames)


class Store:
    """A complete odms-data store, Zarr or HDF5; small arrays are read once and cached."""

    def __init__(self, backend: Backend, path: str, attrs: StoreAttrs) -> None:
        self.backend, self.path, self.attrs = backend, path, attrs
        self.format = backend.format
        self.height, self.width = attrs.image_size
        masks = "masks" in arrays_of(attrs.kind)
        self._masks = backend.array("masks") if masks else None
        self._fast = ShardReader.open(path) if masks and backend.format == "zarr" else None

    # --- sizes -------------------------------------------------------------------------
    @property
    def n_examples(self) -> int:
        return int(self.attrs.counts["examples"])

    @property
    def n_frames(self) -> int:
        return int(self.attrs.counts["frames"])

    def __len__(self) -> int:
        return self.n_examples

    # --- cached small arrays -----------------------------------------------------------
    @property
    def kind(self) -> str:
        """What the examples are made of: "masks" or "boxes" (format.KINDS)."""
        return self.attrs.kind

    def _read(self, name: str) -> np.ndarray:
        if name not in arrays_of(self.kind):
            raise StoreError(f"{self.path}: a store of {self.kind} has no array '{name}'")
        try:
            arr = self.backend.array(name)
            data = np.asarray(arr[...])
        except Exception as e:
            raise StoreError(f"{self.path}: array '{name}' is unreadable ({e})") from e
        if data.shape != tuple(arr.shape):
            raise StoreError(f"{self.path}: array '{name}' read back with shape {data.shape}, "
                             f"not its declared {tuple(arr.shape)}")
        return data

    def _checked(self, data: T, problems: list[str]) -> T:
        """`data`, unless it breaks the format's rules (format.py): then the first one, raised."""
        if problems:
            raise StoreError(f"{self.path}: {problems[0]}; run `odms-data validate` on it")
        return data

    def _name(self, i: int) -> str:
        """Example row i by its id, or by its row when the ids are themselves unreadable."""
        try:
            return repr(self.example_ids[i])
        except StoreError:
            return f"row {i}"

    # Each array is checked against the format's rules when first read; `raw` reads it unchecked.
    def raw(self, name: str) -> np.ndarray:
        """Array `name` as stored, unchecked (for `validate`, which reports every problem)."""
        return self._read(name)

    def checked(self, name: str) -> Any:
        """Array `name` after the format's rules for it (a text array as its strings); an array
        the rules say nothing of, as stored."""
        attribute = _CHECKED.get(name, name)
        return getattr(self, attribute) if hasattr(type(self), attribute) else self._read(name)

    @cached_property
    def z(self) -> np.ndarray:
        z = self._read("z")
        return self._checked(z, z_problems(z))

    @cached_property
    def depth(self) -> np.ndarray:
        depth = self._read("depth")
        return self._checked(depth, depth_problems(depth))

    @cached_property
    def _boxes(self) -> tuple[np.ndarray, np.ndarray]:
        box, move = self._read("box"), self._read("move")
        return self._checked((box, move), box_problems(box, move))

    box = property(lambda self: self._boxes[0], doc="(F, 4) stored boxes [x_c, y_c, w, h].")
    move = property(lambda self: self._boxes[1], doc="(F, 3) stored movements to each example's last frame.")

    @cached_property
    def _stats(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        area, largest, bbox = self._read("area"), self._read("largest_area"), self._read("bbox")
        self._checked(area, stats_problems(area, largest, bbox, self.height, self.width))
        return area, largest, bbox

    area = property(lambda self: self._stats[0], doc="(F,) object pixels of each frame's mask.")
    largest_area = property(lambda self: self._stats[1], doc="(F,) pixels of its largest region.")
    bbox = property(lambda self: self._stats[2], doc="(F, 4) its bounding box x0, y0, x1, y1.")

    @property
    def empty_frames(self) -> np.ndarray:
        """(F,) bool: frames without the object, an empty mask or a missed detection (width 0)."""
        return self.box[:, 2] == 0 if self.kind == "boxes" else self.area == 0

    @cached_property
    def frame_index(self) -> np.ndarray:
        fi = self._read("frame_index")
        return self._checked(fi, frame_index_problems(fi, self.n_frames, self._name))

    @cached_property
    def d1(self) -> np.ndarray:
        d1 = self._read("d1")
        return self._checked(d1, d1_problems(d1, self.attrs.counts["labelled"], self._name))

    @cached_property
    def n_obs(self) -> np.ndarray:
        """(E,) number of frames of each example."""
        return (self.frame_index >= 0).sum(axis=1)

    @cached_property
    def example_ids(self) -> list[str]:
        ids = self._strings("example_id")
        return self._checked(ids, id_problems(ids, self.attrs.split))

    @cached_property
    def sources(self) -> list[str]:
        return self._strings("source")

    def _strings(self, name: str) -> list[str]:
        try:
            return decode_strings(self._read(name))
        except UnicodeDecodeError as e:
            raise StoreError(f"{self.path}: array '{name}' holds invalid UTF-8 ({e})") from e

    @cached_property
    def _id_to_index(self) -> dict[str, int]:
        return {eid: i for i, eid in enumerate(self.example_ids)}

    # --- lookup ------------------------------------------------------------------------
    def index(self, example_id: str) -> int:
        """Row of `example_id`; an unknown id raises InputError naming the closest ones."""
        try:
            return self._id_to_index[example_id]
        except KeyError:
            close = self._closest_ids(example_id)
            hint = f"; did you mean {', '.join(close)}?" if close else ""
            raise InputError(f"{self.path}: no example '{example_id}'{hint}") from None

    def _closest_ids(self, key: str) -> list[str]:
        """The ids a user who typed `key` most likely meant: a bare name without the split; the
        same number with other zero padding (`sim-val/042`, `42`); row `key` of the store; else
        the ids most alike."""
        qualified = f"{self.attrs.split}/{key}"
        if qualified in self._id_to_index:
            return [qualified]
        number = _NUMBERED.fullmatch(key if "/" in key else qualified)
        close: list[str] = []
        if number:
            prefix, n = number[1], int(number[2])
            close = [i for i in self.example_ids if (m := _NUMBERED.fullmatch(i)) and m[1] == prefix
                     and int(m[2]) == n]
            if key.isdigit() and n < self.n_examples and self.example_ids[n] not in close:
                close.append(self.example_ids[n])  # a row index given as the example
        return close or difflib.get_close_matches(key, self.example_ids, n=3)

    def frames_of(self, i: int) -> np.ndarray:
        row = self.frame_index[i]
        return row[row >= 0]

    # --- masks -------------------------------------------------------------------------
    def read_packed(self, start: int, stop: int) -> np.ndarray:
        """Packed masks of frames [start, stop)."""
        if self._masks is None:
            raise StoreError(f"{self.path}: a store of {self.kind} has no masks")
        try:
            return self._fast.read(start, stop) if self._fast else np.asarray(self._masks[start:stop])
        except Exception as e:
            raise StoreError(
                f"{self.path}: masks of frames {start}..{stop - 1} are unreadable ({e})"
            ) from e

    def read_packed_frames(self, frames: np.ndarray) -> np.ndarray:
        """(k, H, ceil(W/8)) packed masks of the given frame rows, read in as few slices as sensible."""
        frames = np.asarray(frames, np.int64)
        if len(frames) == 0:
            return np.zeros((0, self.height, packed_width(self.width)), np.uint8)
        lo, hi = int(frames.min()), int(frames.max()) + 1
        if hi - lo <= 4 * len(frames):
            return self.read_packed(lo, hi)[frames - lo]
        return np.stack([self.read_packed(f, f + 1)[0] for f in frames])

    def read_masks(self, frames: np.ndarray) -> np.ndarray:
        """(k, H, W) bool masks of the given frame rows, read in as few slices as sensible."""
        return unpack(self.read_packed_frames(frames), self.width)

    def example(self, key: int | str, masks: bool = True) -> Example:
        """Example by row or id; `masks=False` skips decoding masks (an empty array)."""
        i = self.index(key) if isinstance(key, str) else int(key)
        if not 0 <= i < self.n_examples:
            raise InputError(f"{self.path}: example row {i} is out of range 0..{self.n_examples - 1}")
        frames = self.frames_of(i)  # rows inside the store: frame_index is checked when read
        boxes, no_masks = self.kind == "boxes", np.zeros((0, self.height, self.width), bool)
        return Example(
            example_id=self.example_ids[i],
            source=self.sources[i],
            d1=float(self.d1[i]),
            frames=frames,
            z=0.0 - self.move[frames, 2] if boxes else self.z[frames],  # boxes: camera z from the last frame
            depth=self.depth[frames],
            masks=self.read_masks(frames) if masks and not boxes else no_masks,
            boxes=self.box[frames] if boxes else None,
        )

    def __iter__(self):
        for i in range(self.n_examples):
            yield self.example(i)

    # --- lifetime ----------------------------------------------------------------------
    def close(self) -> None:
        self.backend.close()

    def __enter__(self) -> Store:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def __repr__(self) -> str:
        return (
            f"Store({self.path!r}, {self.format}, split={self.attrs.split!r}, "
            f"examples={self.n_examples}, frames={self.n_frames})"
        )


def open_store(path: str, *, incomplete: bool = False) -> Store:
    """Open a complete store for reading; an incomplete (unless `incomplete`: the store builder's
    check before its commit) or malformed one raises StoreError."""
    backend = open_backend(str(path), "r")
    try:
        raw = backend.read_attrs()
        if raw is None:
            raise StoreError(f"{path}: not an odms-data store (no 'odms' attribute)")
        if raw.get("complete") is not True:
            if not incomplete:
                raise StoreError(
                    f"{path}: store is incomplete (an interrupted write?); re-run the command that made it"
                )
            raw = {**raw, "complete": True}  # checked as it will be once committed
        missing = sorted(set(arrays_of(kind_of(raw))) - backend.names())
        if missing:
            raise StoreError(f"{path}: store lacks the array(s) {', '.join(missing)}")
        attrs = StoreAttrs.from_json(raw, str(path))
        problems = store_problems(backend, raw)
        if problems:
            raise StoreError(f"{path}: {problems[0]}; run `odms-data validate` on it")
        return Store(backend, str(path), attrs)
    except BaseException:
        backend.close()
        raise
