"""Confidence intervals and paired tests that respect how the data were recorded.

Examples that share a recorded sequence (a robot approach, a SYNTHIA sequence, a recording) are
not independent, so a resample draws whole sequences (clusters) with replacement, as many as the
split has; an example of no recorded sequence (a simulated one) is a cluster of its own. Each
resample's mean of a per-example term is the sum over its drawn clusters divided by their examples
(metrics.TERMS gives the terms; metrics.from_means turns means into metrics). The 95 % interval is
the 2.5th and 97.5th percentile of RESAMPLES resamples. The draws are seeded by SEED and the
split's name, so the same file gives the same interval on any machine, and a split's draws are
the same in `score` and in `compare`. A benchmark's All resamples each of its sets so and takes
the mean over sets of each resample. Method and cost: docs/SCORING.md.

The paired test (`compare`) flips the sign of each cluster's summed difference at random
(FLIPS times, seeded likewise) and counts the flips whose mean difference is at least as far
from 0 as the one observed: a two-sided p-value that assumes only that, where the two methods are
equally good, a cluster's difference is as likely negative as positive.
"""

from __future__ import annotations

import zlib
from collections.abc import Sequence

import numpy as np

RESAMPLES = 2000
FLIPS = 10_000
FLIP_BLOCK = 1000  # flips drawn at once: 1000 x 3,000 clusters is 24 MB
SEED = 39
LEVEL = 0.95


def _rng(split: str, purpose: int) -> np.random.Generator:
    return np.random.default_rng([SEED, purpose, zlib.crc32(split.encode())])


def cluster_codes(sequences: Sequence[str | None]) -> np.ndarray:
    """(n,) cluster number of each example: examples of one named sequence share one, an example
    whose sequence is None is alone."""
    codes: dict[str, int] = {}
    out = np.empty(len(sequences), np.int64)
    for i, s in enumerate(sequences):
        out[i] = codes.setdefault(s if s is not None else f"\0{i}", len(codes))
    return out


def _cluster_sums(terms: np.ndarray, codes: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(K, C) sums of each term over each cluster, and (C,) each cluster's examples."""
    n_clusters = int(codes.max()) + 1 if len(codes) else 0
    counts = np.bincount(codes, minlength=n_clusters).astype(np.float64)
    sums = np.zeros((terms.shape[0], n_clusters))
    for k in range(terms.shape[0]):
        sums[k] = np.bincount(codes, weights=terms[k], minlength=n_clusters)
    return sums, counts


def _draws(n_clusters: int, split: str) -> np.ndarray:
    """(RESAMPLES, C): how often each cluster is drawn in each resample."""
    picks = _rng(split, 0).integers(0, n_clusters, size=(RESAMPLES, n_clusters))
    picks += np.arange(RESAMPLES)[:, None] * n_clusters
    return np.bincount(picks.ravel(), minlength=RESAMPLES * n_clusters).reshape(RESAMPLES, n_clusters)


def resampled_means(terms: np.ndarray, codes: np.ndarray, split: str) -> np.ndarray:
    """(K, RESAMPLES): the mean of each of the K rows of `terms` (K, n) in each cluster resample."""
    sums, counts = _cluster_sums(np.atleast_2d(terms), codes)
    w = _draws(len(counts), split).astype(np.float64)
    with np.errstate(invalid="ignore", over="ignore"):  # an infinite term gives an infinite mean
        return (w @ sums.T / (w @ counts)[:, None]).T


def interval(samples: np.ndarray) -> tuple[float, float]:
    """The LEVEL percentile interval of the resampled values (last axis)."""
    tail = (1 - LEVEL) / 2 * 100
    with np.errstate(invalid="ignore", over="ignore"):  # infinite resamples give an infinite bound
        lo, hi = np.percentile(samples, [tail, 100 - tail], axis=-1)
    return float(lo), float(hi)


def flip_statistics(diffs: np.ndarray, codes: np.ndarray, split: str) -> np.ndarray:
    """(FLIPS,): the mean difference of each random sign flip of the clusters' summed differences
    (each flip's signs are random bits: sum of +-s = 2 * (bits . s) - sum s), FLIP_BLOCK at a time."""
    sums = _cluster_sums(diffs[None, :], codes)[0][0]
    rng, c = _rng(split, 1), len(sums)
    out = np.empty(FLIPS)
    for start in range(0, FLIPS, FLIP_BLOCK):
        rows = min(FLIP_BLOCK, FLIPS - start)
        bits = np.unpackbits(np.frombuffer(rng.bytes(-(-rows * c // 8)), np.uint8))[: rows * c]
        with np.errstate(invalid="ignore", over="ignore"):  # infinite differences flip to NaN
            out[start:start + rows] = 2 * (bits.reshape(rows, c).astype(np.float64) @ sums) - sums.sum()
    return out / len(diffs)


def p_value(observed: float, flipped: np.ndarray) -> float:
    """Two-sided: the share of flips (the observed one counted) at least as far from 0 as observed."""
    tol = 1e-12 * max(1.0, abs(observed))
    return float((1 + np.count_nonzero(np.abs(flipped) >= abs(observed) - tol)) / (len(flipped) + 1))
