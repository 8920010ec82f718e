"""Box examples as DBox's inputs (box_transform.py): freshly generated ones
(simulate/box_examples.py), the box kind's source for every loader's stream, and a store's
(store/box_rule.py: any store, of boxes or of masks through the box rule)."""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np

from ..errors import InputError
from ..simulate.box_examples import BOX_PRESETS, BoxParams, sample_box_examples
from ..store.box_rule import example_boxes
from .box_transform import DBOX_TRANSFORM, BoxTransform
from .store_rows import StoreRows


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
