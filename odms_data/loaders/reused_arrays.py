"""Batch arrays made in the calling process, given out again once nothing else holds them.

A batch of the paper's inputs is large (256 examples of 10 float32 112x112 masks: 128 MB),
beyond what malloc keeps for reuse, so a fresh array for each batch costs a page fault for
every 4 KB written, about a quarter of the time of drawing the batch. Worker processes reuse
shared memory blocks for the same reason (shared_batches.py).
"""

from __future__ import annotations

import sys
import threading
from collections import deque

import numpy as np

_FREE = 3  # references to a free array while it is checked: the deque's, the loop's, getrefcount's


class ReusedArrays:
    """`empty(shape, dtype)` as np.empty, but returning an array it made before when nothing
    else refers to it any more (no batch, view or tensor made from it): the caller's batches
    stay valid for as long as they are kept. Thread-safe; remembers the last `keep` arrays."""

    def __init__(self, keep: int = 64) -> None:
        self._arrays: deque[np.ndarray] = deque(maxlen=keep)
        self._lock = threading.Lock()

    def empty(self, shape: tuple[int, ...], dtype: np.dtype) -> np.ndarray:
        shape, dtype = tuple(shape), np.dtype(dtype)
        with self._lock:
            for a in self._arrays:
                if a.shape == shape and a.dtype == dtype and sys.getrefcount(a) == _FREE:
                    return a
            a = np.empty(shape, dtype)
            self._arrays.append(a)
            return a

    def __getstate__(self) -> dict:
        return {"keep": self._arrays.maxlen}

    def __setstate__(self, state: dict) -> None:
        self.__init__(state["keep"])  # type: ignore[misc]
