"""Where examples come from: a store or the generator, as dicts of NumPy arrays of a model's inputs.

One source per origin, for every kind of example (kinds.py): the transform says which model's
inputs to make, and so which kind of example to read or draw (`Transform`: ODN's, from masks;
`BoxTransform`: DBox's, from boxes), as a torchvision dataset takes its transforms.

Both are plain picklable objects, so they travel to worker processes (PyTorch DataLoader
workers, the NumPy loader's pool). A store is opened lazily in each process: Zarr and HDF5
handles are not safe to share across fork, so a handle opened in another process is dropped
and the store reopened on first use, and its length is read once in the parent.
"""

from __future__ import annotations

import os
from abc import ABC, abstractmethod
from typing import Any

import numpy as np

from ..errors import InputError
from ..store.reader import Store, open_store
from .kinds import KINDS, STANDARD, Empty, Indices, InputTransform, Params, kind_of_params, transform_for


class _Examples(ABC):
    """What both sources share: an example, or a list of examples, out of a batch."""

    @abstractmethod
    def batch(self, indices: Indices, empty: Empty = np.empty) -> dict[str, np.ndarray]: ...

    def example(self, index: int) -> dict[str, np.ndarray]:
        return {key: a[0] for key, a in self.batch([index]).items()}

    def examples(self, indices: Indices) -> list[dict[str, np.ndarray]]:
        made = self.batch(indices)
        return [{key: a[k] for key, a in made.items()} for k in range(len(indices))]


class StoreExamples(_Examples):
    """The examples of the store at `path` as the inputs `transform` makes (None: ODN's paper
    inputs), by row: ODN's from its masks, DBox's from its boxes (a store of masks through the box
    rule); the store is opened on first use in each process."""

    def __init__(self, path: str, transform: InputTransform | None = None) -> None:
        self.path = str(path)
        self.transform = KINDS["masks"].default_transform if transform is None else transform
        self.kind = KINDS[self.transform.kind]
        self._store: Store | None = None
        self._pid: int | None = None
        self._len = len(self.store)

    @property
    def store(self) -> Store:
        if self._store is None or self._pid != os.getpid():
            self._store, self._pid = open_store(self.path), os.getpid()
        return self._store

    def __getstate__(self) -> dict[str, Any]:
        return {**self.__dict__, "_store": None, "_pid": None}

    def __len__(self) -> int:
        return self._len

    def batch(self, indices: Indices, empty: Empty = np.empty) -> dict[str, np.ndarray]:
        """The examples at store rows `indices`, stacked into arrays made by `empty`."""
        rows = np.asarray(indices, np.int64).reshape(-1)
        bad = rows[(rows < 0) | (rows >= self._len)]
        if len(bad):
            raise InputError(f"{self.path}: example row {bad[0]} is out of range 0..{self._len - 1}")
        return self.kind.read(self.store, self.path, rows, self.transform, empty)


class GeneratedExamples(_Examples):
    """Freshly generated examples of (params, seed): masks (GeneratorParams, ODN's inputs through a
    Transform) or boxes (BoxParams, DBox's through a BoxTransform); transform None is the kind's
    own. `example(index)` depends only on (params, seed, index, transform, direct).

    By default the masks are exactly those of a generated store read through the same transform;
    `direct=True` draws them straight at the transform's size instead: faster, but larger
    (kinds.py, docs/LOADERS.md).
    """

    def __init__(self, params: Params = STANDARD, seed: int = 0, transform: InputTransform | None = None,
                 direct: bool = False) -> None:
        if seed < 0:
            raise InputError(f"seed must be a non-negative integer, got {seed}")
        self.kind = kind_of_params(params)
        self.transform = transform_for(self.kind, transform)
        if direct and self.kind is not KINDS["masks"]:
            raise InputError(f"{self.kind.noun} examples have no masks to draw directly; drop `direct`")
        self.transform.select(self.kind.frames(params))  # refuses n_obs > n before any worker starts
        self.params, self.seed, self.direct = params, seed, direct

    def batch(self, indices: Indices, empty: Empty = np.empty) -> dict[str, np.ndarray]:
        """The examples at generator `indices`, drawn together into arrays made by `empty`."""
        return self.kind.draw(self.params, self.seed, indices, self.transform, self.direct, empty)


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
