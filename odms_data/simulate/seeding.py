"""Each example's random generator, `PCG64(SeedSequence(seed, spawn_key=(index,)))`, made for a
whole batch of indices at once.

NumPy builds a SeedSequence and draws the PCG64 state from it in scalar steps, about 30 us a
generator here, a quarter of an example's draws once those are batched. `example_rngs` runs the
same hash (NumPy's SeedSequence: O'Neill's seed_seq_fe mixing of a 4-word pool, uint32
arithmetic) on arrays, one row per index, and hands each PCG64 its state words. NumPy fixes this
algorithm for stream compatibility; tests/simulate/test_seeding.py checks the states against
SeedSequence's.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.random.bit_generator import ISeedSequence

from ..errors import InputError

POOL_SIZE = 4
INIT_A, MULT_A = 0x43B0D7E5, 0x931E8875
INIT_B, MULT_B = 0x8B51F9DD, 0x58F38DED
MIX_MULT_L, MIX_MULT_R = 0xCA01F9DD, 0x4973F715
XSHIFT = 16
BATCHED_FROM = 8  # fewer indices: NumPy's own SeedSequence, faster than array steps for so few


def _words(value: int) -> list[int]:
    """A non-negative integer as little-endian uint32 words (0 is one zero word)."""
    words = []
    while True:
        words.append(value & 0xFFFFFFFF)
        value >>= 32
        if not value:
            return words


class _HashConstant:
    """SeedSequence's hash constant: it steps the same way whatever the data."""

    def __init__(self, value: int, mult: int) -> None:
        self.value, self.mult = np.uint32(value), np.uint32(mult)

    def hashmix(self, v: np.ndarray) -> np.ndarray:
        v = v ^ self.value
        self.value = self.value * self.mult
        v = v * self.value
        return v ^ (v >> XSHIFT)


def _mix(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    r: np.ndarray = np.uint32(MIX_MULT_L) * x - np.uint32(MIX_MULT_R) * y
    return r ^ (r >> XSHIFT)


def _states(entropy: np.ndarray) -> np.ndarray:
    """(B, 4) uint64: `generate_state(4, np.uint64)`, which PCG64 seeds its state and increment
    from, of the SeedSequences whose assembled entropy words are the rows of `entropy` (B, L)."""
    with np.errstate(over="ignore"):
        h = _HashConstant(INIT_A, MULT_A)
        zero = np.zeros(len(entropy), np.uint32)
        pool = [h.hashmix(entropy[:, i] if i < entropy.shape[1] else zero) for i in range(POOL_SIZE)]
        for src in range(POOL_SIZE):
            for dst in range(POOL_SIZE):
                if src != dst:
                    pool[dst] = _mix(pool[dst], h.hashmix(pool[src]))
        for src in range(POOL_SIZE, entropy.shape[1]):
            for dst in range(POOL_SIZE):
                pool[dst] = _mix(pool[dst], h.hashmix(entropy[:, src]))
        h = _HashConstant(INIT_B, MULT_B)
        words32 = np.stack([h.hashmix(pool[i % POOL_SIZE]) for i in range(8)], axis=1)
    return np.ascontiguousarray(words32).view("<u8")


class _Seeded(ISeedSequence):
    """PCG64's seed: the state words `_states` computed."""

    def __init__(self, words: np.ndarray) -> None:
        self.words = words

    def generate_state(self, n_words: int, dtype=np.uint32) -> np.ndarray:
        return self.words


def example_rngs(seed: int, indices: Sequence[int]) -> list[np.random.Generator]:
    """`Generator(PCG64(SeedSequence(seed, spawn_key=(index,))))` for each of `indices`."""
    ints = [int(i) for i in indices]
    if seed < 0 or any(i < 0 for i in ints):
        raise InputError(f"seeds and example indices are non-negative integers, got seed {seed}, "
                         f"smallest index {min(ints, default=0)}")
    if len(ints) < BATCHED_FROM:
        return [np.random.Generator(np.random.PCG64(np.random.SeedSequence(seed, spawn_key=(i,))))
                for i in ints]
    run = _words(seed)
    run += [0] * (POOL_SIZE - len(run))  # SeedSequence pads the run entropy when spawned
    spawn = [_words(i) for i in ints]
    out: list[np.random.Generator] = [None] * len(spawn)  # type: ignore[list-item]
    for length in {len(s) for s in spawn}:
        rows = [k for k, s in enumerate(spawn) if len(s) == length]
        entropy = np.array([run + spawn[k] for k in rows], np.uint32)
        for k, words in zip(rows, _states(entropy), strict=True):
            # PCG64 takes any ISeedSequence; NumPy's stubs name SeedSequence alone
            out[k] = np.random.Generator(np.random.PCG64(_Seeded(words)))  # type: ignore[arg-type]
    return out
