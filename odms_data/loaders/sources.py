"""Where examples come from: a store or the generator, as dicts of NumPy network inputs.

Both are plain picklable objects, so they travel to worker processes (PyTorch DataLoader
workers, the NumPy loader's pool). A store is opened lazily in each process: Zarr and HDF5
handles are not safe to share across fork, so a handle opened in another process is dropped
and the store reopened on first use.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Sequence

import numpy as np

from ..errors import InputError
from ..simulate.batch_render import render_masks, render_shrunk
from ..simulate.box_examples import BOX_PRESETS, BoxParams, sample_box_examples
from ..simulate.object_model import sample_examples
from ..simulate.params import PRESETS, GeneratorParams
from ..simulate.shrink import shrink_packed
from ..store.box_rule import example_boxes
from ..store.masks import unpack
from ..store.reader import Store, open_store
from .box_transform import DBOX_TRANSFORM, BoxTransform
from .transforms import PAPER_TRANSFORM, Transform

STANDARD = PRESETS["standard"]
RENDER_CHUNK = 32  # examples drawn together: bounds the scratch images to a few MB


Indices = Sequence[int] | np.ndarray  # example rows or generator indices
Empty = Callable[[tuple[int, ...], np.dtype], np.ndarray]  # allocates a batch's array


def collate(examples: list[dict[str, np.ndarray]], empty: Empty = np.empty) -> dict[str, np.ndarray]:
    """Stack examples' arrays along a new first axis, into arrays made by `empty`."""
    out = {}
    for key in examples[0]:
        first = np.asarray(examples[0][key])
        into = empty((len(examples), *first.shape), first.dtype)
        try:
            out[key] = np.stack([e[key] for e in examples], out=into)
        except ValueError:
            shapes = sorted({np.shape(e[key]) for e in examples})
            raise InputError(
                f"cannot batch '{key}': examples give shapes {shapes}; set the transform's n_obs "
                "so every example has as many observations"
            ) from None
    return out


class StoreRows:
    """The store at `path`, opened on first use in each process; `len` is its number of examples."""

    def __init__(self, path: str) -> None:
        self.path = str(path)
        self._store: Store | None = None
        self._pid: int | None = None
        self._len = len(self.store)

    @property
    def store(self) -> Store:
        if self._store is None or self._pid != os.getpid():
            self._store, self._pid = open_store(self.path), os.getpid()
        return self._store

    def __getstate__(self) -> dict:
        return {**self.__dict__, "_store": None, "_pid": None}

    def __len__(self) -> int:
        return self._len


class StoreExamples(StoreRows):
    """The examples of the store at `path`, transformed; `example(i)` by row."""

    def __init__(self, path: str, transform: Transform = PAPER_TRANSFORM) -> None:
        self.transform = transform
        super().__init__(path)

    def _chosen(self, i: int) -> np.ndarray:
        """Frame rows of the observations of example i the transform uses."""
        if not 0 <= i < self._len:
            raise InputError(f"{self.path}: example row {i} is out of range 0..{self._len - 1}")
        frames = self.store.frames_of(i)
        try:
            return frames[self.transform.select(len(frames))]
        except InputError as e:
            raise InputError(f"{self.path}: example {self.store.example_ids[i]}: {e}") from None

    def _inputs(
        self, i: int, chosen: np.ndarray, packed: np.ndarray, masks: np.ndarray | None = None
    ) -> dict[str, np.ndarray]:
        """Example i's inputs from the packed masks of its frames `chosen`; shrunk masks are
        written into `masks` when given."""
        s, t = self.store, self.transform
        if t.size is None:
            out = t(unpack(packed, s.width), s.z[chosen], float(s.d1[i]))
        else:  # read and shrink only the stored boxes: the same pixels
            shrunk = shrink_packed(packed, s.width, s.bbox[chosen], t.size, not t.rounded, masks)
            out = {"masks": shrunk, **t.vectors(s.z[chosen], float(s.d1[i]), t.size)}
        out["index"] = np.int64(i)
        return out

    def example(self, i: int) -> dict[str, np.ndarray]:
        chosen = self._chosen(i)
        return self._inputs(i, chosen, self.store.read_packed_frames(chosen))

    def batch(self, indices: Indices, empty: Empty = np.empty) -> dict[str, np.ndarray]:
        """Examples by row, stacked into arrays made by `empty`; shrunk masks are written into
        the batch's array directly."""
        t = self.transform
        read = self._read(indices)
        if t.size is None or len({len(c) for _, c, _ in read}) > 1:  # collate says what differs
            return collate([self._inputs(*r) for r in read], empty)
        dtype = np.dtype(np.uint8 if t.rounded else np.float32)
        masks = empty((len(read), len(read[0][1]), *t.size), dtype)
        rest = [self._inputs(*r, masks=m) for r, m in zip(read, masks, strict=True)]
        for e in rest:
            del e["masks"]
        return {"masks": masks, **collate(rest, empty)}

    def examples(self, indices: Indices) -> list[dict[str, np.ndarray]]:
        """Examples by row."""
        return [self._inputs(*r) for r in self._read(indices)]

    def _read(self, indices: Indices) -> list[tuple[int, np.ndarray, np.ndarray]]:
        """(row, chosen frames, their packed masks) of each row; the packed masks of nearby rows
        are read in one slice."""
        rows = [int(i) for i in indices]
        chosen = [self._chosen(i) for i in rows]
        flat = np.concatenate(chosen)
        lo, hi = int(flat.min()), int(flat.max()) + 1
        pairs = zip(rows, chosen, strict=True)
        if hi - lo > 4 * len(flat):
            return [(i, c, self.store.read_packed_frames(c)) for i, c in pairs]
        packed = self.store.read_packed(lo, hi)
        return [(i, c, packed[c - lo]) for i, c in pairs]


class GeneratedExamples:
    """Freshly generated examples of (params, seed); `example(index)` depends only on
    (params, seed, index, transform, direct).

    By default the masks are exactly those of a generated store read through the same transform
    (full-size masks shrunk with INTER_AREA), drawn without a full-size frame (batch_render.render_shrunk).
    `direct=True` draws the contour straight at the transform's size instead (the generator's own
    small-size rendering): faster, but its masks are larger; see docs/LOADERS.md.
    """

    def __init__(
        self,
        params: GeneratorParams = STANDARD,
        seed: int = 0,
        transform: Transform = PAPER_TRANSFORM,
        direct: bool = False,
    ) -> None:
        if seed < 0:
            raise InputError(f"seed must be a non-negative integer, got {seed}")
        self.params, self.seed, self.transform, self.direct = params, seed, transform, direct
        self._chosen = transform.select(params.n_obs)

    def example(self, index: int) -> dict[str, np.ndarray]:
        return {key: a[0] for key, a in self.batch([index]).items()}

    def batch(self, indices: Indices, empty: Empty = np.empty) -> dict[str, np.ndarray]:
        """The examples at generator `indices`, drawn together (simulate.batch_render) into arrays made by
        `empty`, a few dozen examples at a time."""
        p, t, chosen = self.params, self.transform, self._chosen
        specs = sample_examples(p, self.seed, indices)
        size = t.size or p.image_size
        dtype = np.dtype(np.uint8 if t.rounded else np.float32)
        masks = empty((len(specs), len(chosen), *size), dtype)
        for start in range(0, len(specs), RENDER_CHUNK):
            part, into = specs[start : start + RENDER_CHUNK], masks[start : start + RENDER_CHUNK]
            if t.size is not None and not self.direct:
                render_shrunk(part, p, size, chosen, not t.rounded, into)
            elif dtype == np.uint8:
                render_masks(part, p, t.size, chosen, into)
            else:  # coverage of masks at their drawn size: the 0/1 masks as float32
                into[...] = render_masks(part, p, t.size, chosen)
        vectors = collate([t.vectors(s.z[chosen], float(s.z[0]), size) for s in specs], empty)
        index = empty((len(specs),), np.dtype(np.int64))
        index[...] = indices
        return {"masks": masks, **vectors, "index": index}


class GeneratedBoxExamples:
    """The box examples of (params, seed), transformed; `example(index)` depends only on
    (params, seed, index, transform)."""

    def __init__(self, params: BoxParams = BOX_PRESETS["odmd"], seed: int = 0,
                 transform: BoxTransform = DBOX_TRANSFORM) -> None:
        if seed < 0:
            raise InputError(f"seed must be a non-negative integer, got {seed}")
        transform.select(params.num_pos)  # refuses n_obs > num_pos before any worker starts
        self.params, self.seed, self.transform = params, seed, transform

    def example(self, index: int) -> dict[str, np.ndarray]:
        return {key: a[0] for key, a in self.batch([index]).items()}

    def batch(self, indices: Sequence[int] | np.ndarray,
              empty: Callable[[tuple[int, ...], np.dtype], np.ndarray] = np.empty) -> dict[str, np.ndarray]:
        """The examples at generator `indices`, in arrays made by `empty` (as sources.collate)."""
        g = sample_box_examples(self.params, self.seed, indices)
        made = self.transform.batch(g["boxes"], g["move"], g["depth"])
        out = {}
        for key, a in made.items():
            out[key] = empty(a.shape, a.dtype)
            out[key][...] = a
        index = empty((len(a),), np.dtype(np.int64))
        index[...] = indices
        return {**out, "index": index}


class StoreBoxExamples(StoreRows):
    """The examples of the store at `path` as box examples (store/box_rule.py), transformed;
    `example(i)` by row."""

    def __init__(self, path: str, transform: BoxTransform = DBOX_TRANSFORM) -> None:
        self.transform = transform
        super().__init__(path)

    def example(self, i: int) -> dict[str, np.ndarray]:
        return {key: a[0] for key, a in self.batch([i]).items()}

    def examples(self, indices: Sequence[int] | np.ndarray) -> list[dict[str, np.ndarray]]:
        made = self.batch(indices)
        return [{key: a[k] for key, a in made.items()} for k in range(len(indices))]

    def batch(self, indices: Sequence[int] | np.ndarray,
              empty: Callable[[tuple[int, ...], np.dtype], np.ndarray] = np.empty) -> dict[str, np.ndarray]:
        """The examples at store rows `indices`, in arrays made by `empty` (as sources.collate)."""
        rows = np.asarray(indices, np.int64)
        bad = rows[(rows < 0) | (rows >= self._len)]
        if len(bad):
            raise InputError(f"{self.path}: example row {bad[0]} is out of range 0..{self._len - 1}")
        e = example_boxes(self.store, rows, self.transform.n_obs)
        try:
            made = self.transform.batch(e.boxes, e.move, e.depth)
        except InputError as e:
            raise InputError(f"{self.path}: {e}") from None
        out = {}
        for key, a in {**made, "index": rows}.items():
            out[key] = empty(a.shape, a.dtype)
            out[key][...] = a
        return out


def generated_examples(
    params: GeneratorParams | BoxParams, seed: int, transform: Transform | BoxTransform, direct: bool = False
) -> GeneratedExamples | GeneratedBoxExamples:
    """The stream's source for the kind of example `params` makes: masks (GeneratorParams, with a
    Transform) or boxes (BoxParams, with a BoxTransform; the loaders' default Transform stands for
    DBox's)."""
    if isinstance(params, BoxParams):
        transform = DBOX_TRANSFORM if transform == PAPER_TRANSFORM else transform
        if not isinstance(transform, BoxTransform) or direct:
            raise InputError("box examples take a BoxTransform (DBox's inputs) and no direct drawing")
        return GeneratedBoxExamples(params, seed, transform)
    if isinstance(transform, BoxTransform):
        raise InputError("mask examples take a Transform; a BoxTransform needs box generator parameters")
    return GeneratedExamples(params, seed, transform, direct)


def store_examples(path: str, transform: Transform | BoxTransform = PAPER_TRANSFORM
                   ) -> StoreExamples | StoreBoxExamples:
    """The store's source for the kind of input `transform` makes: ODN's from masks (Transform) or
    DBox's from boxes (BoxTransform: a store of boxes, or of masks through the box rule)."""
    if isinstance(transform, BoxTransform):
        return StoreBoxExamples(path, transform)
    return StoreExamples(path, transform)


def stream_indices(batch: int, batch_size: int, batches_per_epoch: int, epoch: int) -> range:
    """Generator indices of batch `batch` of `epoch`: epochs and batches take consecutive,
    disjoint blocks of the index space, so no example repeats across batches, workers or epochs."""
    start = (epoch * batches_per_epoch + batch) * batch_size
    return range(start, start + batch_size)


def store_order(n: int, shuffle: bool, seed: int, epoch: int) -> np.ndarray:
    """Rows of a store in the order of `epoch`: a permutation drawn from (seed, epoch) or 0..n-1."""
    if not shuffle:
        return np.arange(n)
    return np.random.default_rng([seed, epoch]).permutation(n)
