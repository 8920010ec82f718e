"""Freshly generated box examples (simulate/box_examples.py) as DBox's inputs
(box_transform.py): the box kind's source for every loader's stream."""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np

from ..errors import InputError
from ..simulate.box_examples import BOX_PRESETS, BoxParams, sample_box_examples
from .box_transform import DBOX_TRANSFORM, BoxTransform


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
