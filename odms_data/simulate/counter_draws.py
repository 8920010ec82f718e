"""Counter-based random draws: draw j of example i is a pure function of (seed, i, j), so any
example is made on its own and a whole batch of them in a few array operations.

Each example has a 64-bit key, `mix64(seed key ^ mix64((i + 1) * GOLDEN))`, distinct for distinct
indices of a seed (mix64 is a bijection); its draw j is `mix64(key ^ mix64((j + 1) * GOLDEN))`. mix64 is
SplitMix64's output function (Steele, Lea & Flood, OOPSLA 2014; Stafford's variant 13), and
SplitMix64 is this with an added counter in place of the xor. The seed key folds the seed's
64-bit words through mix64, so any non-negative integer seeds.

Uniforms come in pairs from one draw, its two 32-bit halves (a resolution of 2^-32, 1e-10 m on
the generator's scales). Normals come in pairs from one
draw by Box-Muller, in float32 (each normal to about 1e-7; NumPy's float64 logarithm and
trigonometry are many times slower and were most of a batch's time): the top 24 bits give the
radius (|x| at most 5.9, which a normal passes once in 3e8), the low 24 the angle.
"""

from __future__ import annotations

import functools
from collections.abc import Sequence

import numpy as np

from ..errors import InputError

GOLDEN = np.uint64(0x9E3779B97F4A7C15)
MUL_1, MUL_2 = np.uint64(0xBF58476D1CE4E5B9), np.uint64(0x94D049BB133111EB)
SHIFTS = (np.uint64(30), np.uint64(27), np.uint64(31))
TWO_32 = 2.0 ** -32


def mix64(z: np.ndarray) -> np.ndarray:
    """SplitMix64's output function of each uint64 of the array `z` (its products wrap modulo
    2^64, silently for arrays), in place (z is returned)."""
    tmp = np.empty_like(z)
    for shift, mul in zip(SHIFTS, (MUL_1, MUL_2, None), strict=True):
        np.right_shift(z, shift, out=tmp)
        np.bitwise_xor(z, tmp, out=z)
        if mul is not None:
            np.multiply(z, mul, out=z)
    return z


@functools.lru_cache(maxsize=64)
def _counters(first: int, count: int) -> np.ndarray:
    """(count, 1) uint64: the hashed counters of draws first .. first + count - 1 (read only)."""
    c = mix64(np.arange(first + 1, first + count + 1, dtype=np.uint64) * GOLDEN)[:, None]
    c.flags.writeable = False
    return c


def example_keys(seed: int, indices: Sequence[int] | np.ndarray) -> np.ndarray:
    """(B,) uint64: each example's key from the seed and its index (non-negative, below 2^63)."""
    idx = np.asarray(indices, dtype=np.int64).reshape(-1)
    if seed < 0 or (len(idx) and idx.min() < 0):
        raise InputError(f"seeds and example indices are non-negative integers, got seed {seed}, "
                         f"smallest index {idx.min() if len(idx) else 0}")
    key = np.zeros(1, np.uint64)
    while True:  # the seed's words, low first; 0 is one word
        key = mix64(key ^ np.uint64(seed & 0xFFFFFFFFFFFFFFFF))
        seed >>= 64
        if not seed:
            break
    return mix64(mix64((idx.astype(np.uint64) + np.uint64(1)) * GOLDEN) ^ key)


def draws(keys: np.ndarray, first: int, count: int) -> np.ndarray:
    """(count, B) uint64: draws first .. first + count - 1 of each key's stream, a row a draw."""
    return mix64(np.bitwise_xor(_counters(first, count), keys))


def uniforms(keys: np.ndarray, first: int, count: int) -> np.ndarray:
    """(count, B) float64 in [0, 1), multiples of 2^-32, from draws first .. first + ceil(count / 2) - 1:
    each draw's top half, then its bottom half."""
    d = draws(keys, first, (count + 1) // 2)
    out = np.empty((2 * d.shape[0], len(keys)))
    np.multiply(d >> np.uint64(32), TWO_32, out=out[0::2])
    np.multiply(d & np.uint64(0xFFFFFFFF), TWO_32, out=out[1::2])
    return out[:count]


def normals(keys: np.ndarray, first: int, count: int) -> np.ndarray:
    """(count, B) float64 standard normals from draws first .. first + ceil(count / 2) - 1."""
    d = draws(keys, first, (count + 1) // 2)
    radius = (d >> np.uint64(40)).astype(np.float32)
    radius += np.float32(0.5)
    radius *= np.float32(2.0 ** -24)
    np.log(radius, out=radius)
    radius *= np.float32(-2)
    np.sqrt(radius, out=radius)
    angle = (d & np.uint64(0xFFFFFF)).astype(np.float32)
    angle *= np.float32(2 * np.pi * 2.0 ** -24)
    out = np.empty((2 * d.shape[0], len(keys)))
    np.multiply(radius, np.cos(angle), out=out[0::2])
    np.multiply(radius, np.sin(angle), out=out[1::2])
    return out[:count]
