"""The ODMS object model: the random draws of one example (Griffin & Corso, ECCV 2020, section 5.1
and equation 20); `render` draws them.

Each example depends only on (seed, index): its random stream is
`PCG64(SeedSequence(seed, spawn_key=(index,)))`, drawn in a fixed order (camera positions,
shape choices, contour points with their spacing redraws, then one perturbation per frame when perturbing).
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass
from functools import lru_cache
from typing import cast

import numpy as np

from .params import GeneratorParams
from .seeding import example_rngs

SPACING_BLOCK = 8  # contour-point tries drawn at once at first; the block doubles each round


@dataclass
class ExampleSpec:
    """The random draws of one example, before rendering."""

    z: np.ndarray  # (n,) camera positions, m, ascending; d1 = z[0]
    contour: np.ndarray  # (m, 2) closed contour, px at scale 1, x right, y down, in [0, size]^2
    size: int  # s_p
    perturb: np.ndarray  # (n,) eq. 20 draws p (zeros when not perturbing)


def sample_example(params: GeneratorParams, seed: int, index: int) -> ExampleSpec:
    """Draw camera positions, contour and perturbations of example `index` of `seed`."""
    return sample_examples(params, seed, [index])[0]


def sample_examples(params: GeneratorParams, seed: int, indices: Iterable[int]) -> list[ExampleSpec]:
    """`sample_example` of each of `indices`. The draws are made example by example; the contours
    of the examples with the same number of points are computed together, with the same
    element-wise operations, so the result does not depend on what else is in the batch."""
    p = params
    firsts = [_first_draws(p, rng) for rng in example_rngs(seed, list(indices))]
    contours: list[np.ndarray] = [np.empty(0)] * len(firsts)
    for n, members in _by_point_count([f.n_points for f in firsts]).items():
        unit = _spaced_points([firsts[i].rng for i in members], n, p.min_spacing / n, p.spacing_tries)
        sizes = np.array([firsts[i].size for i in members])
        radii = np.array([firsts[i].radius for i in members])
        weights = np.array([_tangent_weight(firsts[i].rotation) for i in members])
        curves = _bezier_contours(unit * sizes[:, None, None], radii, weights, p.curve_samples)
        for k, i in enumerate(members):
            contours[i] = curves[k]
    return [
        ExampleSpec(
            z=f.z, contour=c, size=int(f.size),
            perturb=f.rng.normal(0.0, p.perturb_std, p.n_obs) if p.perturb_std > 0 else np.zeros(p.n_obs),
        )
        for f, c in zip(firsts, contours, strict=True)
    ]


@dataclass
class _FirstDraws:
    """An example's draws before its contour points, and its generator, positioned after them."""

    rng: np.random.Generator
    z: np.ndarray
    size: int
    n_points: int
    radius: float
    rotation: float


def _first_draws(p: GeneratorParams, rng: np.random.Generator) -> _FirstDraws:
    z1 = p.d_min + rng.random() * (p.d_max - p.dz_min - p.d_min)
    zn = z1 + p.dz_min + rng.random() * (p.d_max - p.dz_min - z1)
    inner = np.sort(z1 + rng.random(p.n_obs - 2) * (zn - z1))
    return _FirstDraws(
        rng=rng,
        z=np.concatenate([[z1], inner, [zn]]),
        size=p.sizes[rng.integers(len(p.sizes))],
        n_points=p.n_points[rng.integers(len(p.n_points))],
        radius=p.bezier_radius[rng.integers(len(p.bezier_radius))],
        rotation=p.bezier_rotation[rng.integers(len(p.bezier_rotation))],
    )


def _by_point_count(counts: list[int]) -> dict[int, list[int]]:
    """Positions of the examples with each number of contour points."""
    groups: dict[int, list[int]] = {}
    for i, n in enumerate(counts):
        groups.setdefault(n, []).append(i)
    return groups


def _angular_order(points: np.ndarray) -> np.ndarray:
    """(..., n, 2) point sets, each ordered by angle around its centroid."""
    c = np.add.reduce(points, axis=-2) / points.shape[-2]  # points.mean(axis=-2), without its overhead
    angle = np.arctan2(points[..., 1] - c[..., 1:], points[..., 0] - c[..., :1])
    return np.take_along_axis(points, np.argsort(angle, axis=-1)[..., None], axis=-2)


def _next(a: np.ndarray) -> np.ndarray:
    """np.roll(a, -1, axis=1): each point's successor around its loop."""
    return np.concatenate((a[:, 1:], a[:, :1]), axis=1)


@lru_cache(maxsize=8)
def _bernstein(samples: int) -> tuple[np.ndarray, ...]:
    """The cubic Bernstein weights at `samples` steps, shaped (1, samples, 1)."""
    t = np.linspace(0.0, 1.0, samples, endpoint=False)[None, :, None]
    weights = (1 - t) ** 3, 3 * (1 - t) ** 2 * t, 3 * (1 - t) * t**2, t**3
    for b in weights:
        b.flags.writeable = False
    return weights


@lru_cache(maxsize=64)
def _tangent_weight(rotation: float) -> float:
    """w = arctan(rotation)/pi + 1/2, the weight of the outgoing chord's direction."""
    return float(np.arctan(rotation) / np.pi + 0.5)


def spaced_points(rng: np.random.Generator, n: int, min_gap: float, tries: int) -> np.ndarray:
    """n points uniform in the unit square (drawn from `rng`, a PCG64 Generator such as
    np.random.default_rng makes), ordered by angle around their centroid, redrawn
    (at most `tries` draws, the last kept) until |dx + dy| >= min_gap for every two consecutive
    points of that order, first to last: the released generator's rule, which measures no gap
    from the last point back to the first, and |dx + dy| rather than the distance.

    Without a spacing rule thin slivers are common, and VOS-DE on the simulated set lands about
    one point above the official normal set. docs/FIDELITY.md compares the rules.
    """
    return _spaced_points([rng], n, min_gap, tries)[0]


def _spaced_points(rngs: list[np.random.Generator], n: int, min_gap: float, tries: int) -> np.ndarray:
    """(len(rngs), n, 2): `spaced_points` from each generator (PCG64, as `example_rngs` makes),
    the tries of all drawn in blocks.

    Each generator draws a block of tries; the first good one is kept and the generator is
    stepped back over the tries after it (PCG64.advance by minus their draws), so it ends where
    drawing one try at a time would have left it. The step back drops PCG64's buffered half
    word, which only 32-bit draws use, and the draws that follow are 64-bit (normal).
    """
    out = np.empty((len(rngs), n, 2))
    todo, tried, block = list(range(len(rngs))), 0, SPACING_BLOCK
    while todo:
        k = min(block, tries - tried)
        candidates = np.empty((len(todo), k, n, 2))
        for j, i in enumerate(todo):
            rngs[i].random(out=candidates[j])
        pts = _angular_order(candidates)
        steps = pts[..., 1:, :] - pts[..., :-1, :]
        good = np.abs(steps[..., 0] + steps[..., 1]).min(axis=-1) >= min_gap
        tried += k
        first = np.where(good.any(axis=1), good.argmax(axis=1), k - 1 if tried == tries else -1)
        for j, i in enumerate(todo):
            if first[j] >= 0:
                out[i] = pts[j, first[j]]
                if first[j] < k - 1:
                    cast(np.random.PCG64, rngs[i].bit_generator).advance(-(k - 1 - int(first[j])) * 2 * n)
        todo = [i for j, i in enumerate(todo) if first[j] < 0]
        block *= 2
    return out


def _bezier_contours(points: np.ndarray, radius: np.ndarray, weight: np.ndarray, samples: int) -> np.ndarray:
    """(G, n * samples, 2): closed curves through each of the G point sets `points` (G, n, 2),
    of cubic Beziers.

    The tangent at each point mixes the directions of its incoming and outgoing chords with the
    set's `weight` w (`_tangent_weight`); the inner control points sit at the set's `radius`
    times the chord length along those tangents.
    """
    p0 = _angular_order(points)
    p3 = _next(p0)
    chord = p3 - p0
    theta = np.mod(np.arctan2(chord[..., 1], chord[..., 0]), 2 * np.pi)
    prev = np.concatenate((theta[:, -1:], theta[:, :-1]), axis=1)
    w = weight[:, None]
    tangent = w * theta + (1 - w) * prev + np.pi * (np.abs(prev - theta) > np.pi)
    r = (radius[:, None] * np.hypot(chord[..., 0], chord[..., 1]))[..., None]
    direction = np.empty(p0.shape)
    np.cos(tangent, out=direction[..., 0])
    np.sin(tangent, out=direction[..., 1])
    p1 = p0 + r * direction
    p2 = p3 - r * _next(direction)
    b0, b1, b2, b3 = _bernstein(samples)
    curve = b0 * p0[:, :, None] + b1 * p1[:, :, None] + b2 * p2[:, :, None] + b3 * p3[:, :, None]
    return curve.reshape(len(points), -1, 2)
