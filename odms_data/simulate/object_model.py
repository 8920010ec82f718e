"""The ODMS object model: the random draws of one example (Griffin & Corso, ECCV 2020, section 5.1
and equation 20); `render` draws them.

Each example depends only on (seed, index): its random stream is
`PCG64(SeedSequence(seed, spawn_key=(index,)))`, drawn in a fixed order (camera positions,
shape choices, contour points with their spacing redraws, then one perturbation per frame when perturbing).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from .params import GeneratorParams


@dataclass
class ExampleSpec:
    """The random draws of one example, before rendering."""

    z: np.ndarray  # (n,) camera positions, m, ascending; d1 = z[0]
    contour: np.ndarray  # (m, 2) closed contour, px at scale 1, x right, y down, in [0, size]^2
    size: int  # s_p
    perturb: np.ndarray  # (n,) eq. 20 draws p (zeros when not perturbing)


def example_rng(seed: int, index: int) -> np.random.Generator:
    return np.random.Generator(np.random.PCG64(np.random.SeedSequence(seed, spawn_key=(index,))))


def sample_example(params: GeneratorParams, seed: int, index: int) -> ExampleSpec:
    """Draw camera positions, contour and perturbations of example `index` of `seed`."""
    p, rng = params, example_rng(seed, index)
    z1 = p.d_min + rng.random() * (p.d_max - p.dz_min - p.d_min)
    zn = z1 + p.dz_min + rng.random() * (p.d_max - p.dz_min - z1)
    inner = np.sort(z1 + rng.random(p.n_obs - 2) * (zn - z1))
    z = np.concatenate([[z1], inner, [zn]])
    size = p.sizes[rng.integers(len(p.sizes))]
    n_points = p.n_points[rng.integers(len(p.n_points))]
    radius = p.bezier_radius[rng.integers(len(p.bezier_radius))]
    rotation = p.bezier_rotation[rng.integers(len(p.bezier_rotation))]
    points = spaced_points(rng, n_points, p.min_spacing / n_points, p.spacing_tries) * size
    contour = bezier_contour(points, radius, rotation, p.curve_samples)
    perturb = rng.normal(0.0, p.perturb_std, p.n_obs) if p.perturb_std > 0 else np.zeros(p.n_obs)
    return ExampleSpec(z=z, contour=contour, size=int(size), perturb=perturb)


def _angular_order(points: np.ndarray) -> np.ndarray:
    c = np.add.reduce(points, axis=0) / len(points)  # points.mean(axis=0), without its overhead
    return points[np.argsort(np.arctan2(points[:, 1] - c[1], points[:, 0] - c[0]))]


def _next(a: np.ndarray) -> np.ndarray:
    """np.roll(a, -1, axis=0): each row's successor around the loop."""
    return np.concatenate((a[1:], a[:1]))


@lru_cache(maxsize=8)
def _bernstein(samples: int) -> tuple[np.ndarray, ...]:
    """The cubic Bernstein weights at `samples` steps, shaped (1, samples, 1)."""
    t = np.linspace(0.0, 1.0, samples, endpoint=False)[None, :, None]
    weights = (1 - t) ** 3, 3 * (1 - t) ** 2 * t, 3 * (1 - t) * t**2, t**3
    for b in weights:
        b.flags.writeable = False
    return weights


def spaced_points(rng: np.random.Generator, n: int, min_gap: float, tries: int) -> np.ndarray:
    """n points uniform in the unit square, ordered by angle around their centroid, redrawn
    (at most `tries` draws, the last kept) until |dx + dy| >= min_gap for every two consecutive
    points of that order, first to last: the released generator's rule, which measures no gap
    from the last point back to the first, and |dx + dy| rather than the distance.

    Without a spacing rule thin slivers are common, and VOS-DE on the simulated set lands about
    one point above the official normal set. schemas/FIDELITY.md compares the rules.
    """
    for _ in range(tries):
        pts = _angular_order(rng.random((n, 2)))
        steps = pts[1:] - pts[:-1]
        if np.abs(steps[:, 0] + steps[:, 1]).min() >= min_gap:
            break
    return pts


def bezier_contour(points: np.ndarray, radius: float, rotation: float, samples: int) -> np.ndarray:
    """Closed curve through `points` (ordered by angle around their centroid) of cubic Beziers.

    The tangent at each point mixes the directions of its incoming and outgoing chords with
    weight w = arctan(rotation)/pi + 1/2; the inner control points sit at `radius` times the
    chord length along those tangents.
    """
    p0 = _angular_order(points)
    p3 = _next(p0)
    chord = p3 - p0
    theta = np.mod(np.arctan2(chord[:, 1], chord[:, 0]), 2 * np.pi)
    prev = np.concatenate((theta[-1:], theta[:-1]))
    w = np.arctan(rotation) / np.pi + 0.5
    tangent = w * theta + (1 - w) * prev + np.pi * (np.abs(prev - theta) > np.pi)
    r = (radius * np.hypot(chord[:, 0], chord[:, 1]))[:, None]
    direction = np.empty((len(p0), 2))
    np.cos(tangent, out=direction[:, 0])
    np.sin(tangent, out=direction[:, 1])
    p1 = p0 + r * direction
    p2 = p3 - r * _next(direction)
    b0, b1, b2, b3 = _bernstein(samples)
    curve = b0 * p0[:, None] + b1 * p1[:, None] + b2 * p2[:, None] + b3 * p3[:, None]
    return curve.reshape(-1, 2)
