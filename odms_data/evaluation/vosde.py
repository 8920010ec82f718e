"""VOS-DE, the ODMS baseline (Griffin, Florence & Corso, WACV 2020; ODMS paper, appendix).

An object's projected area a_i shrinks with depth, so (z_i - z_obj) * sqrt(a_i) is constant.
With dz_i = z_i - z_1, least squares over the observations of

    [sqrt(a_i), 1] [x0, c]^T = dz_i * sqrt(a_i)

gives x0 = z_obj - z_1 and the estimate d1 = -x0. a_i is the area of the mask's largest
8-connected region (0 for an empty mask), read from the store's `largest_area`, so no mask is
decoded. With more than N observations, N evenly spaced ones are used:
`numpy.linspace(0, n - 1, N)` truncated to integers; N beyond an example's n is refused, as every
command refuses it (protocol.observation_indices), where the authors' code used all n.

Degenerate inputs, as the authors' released code treats them: the normal equations are solved
with LAPACK (the same factorisation as the released code's matrix inverse); an example whose
A^T A is singular (every used mask with the same area, e.g. all empty) is *unsolvable* and
predicts 0, which scores as 100% error; so is one whose camera never moved (its solution, 0 m,
was counted as solved). Examples with empty masks among the used observations
are solved as they are (an empty mask has area 0) and counted.

On the official splits this reproduces the released code's figures for n = 10 (and the
paper's, except test driving: 35.76 against the printed 36.0) and the paper's n = 2 figures.
The paper's n = 3 and n = 5 robot and driving figures come from some other choice of
observations and are not reproduced by this linspace rule.
"""

from __future__ import annotations

import numpy as np

from ..errors import InputError
from ..protocol import observation_indices
from ..store.reader import Store
from .baseline_result import BaselineResult
from .least_squares import first_unknown, unmoved

DEFAULT_N_OBS = 10


def solve(sqrt_area: np.ndarray, dz: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Batched VOS-DE on (E, k) arrays: (d1 estimates, unsolvable, ill-conditioned)."""
    A = np.stack([sqrt_area, np.ones_like(sqrt_area)], axis=-1)  # (E, k, 2)
    x0, bad, ill = first_unknown(A, dz * sqrt_area)
    bad |= unmoved(dz)
    return 0.0 - np.where(bad, 0.0, x0), bad, ill & ~bad  # not -x0: an unsolvable row stays 0.0, not -0.0


def vosde(store: Store, n_obs: int = DEFAULT_N_OBS) -> BaselineResult:
    """VOS-DE estimates for every example of `store` (d1 at the first observation) from its stored
    per-frame statistics; it flags examples with an empty mask among the used observations."""
    if n_obs < 2:
        raise InputError(f"n_obs must be at least 2 (two unknowns), got {n_obs}")
    fi, counts = store.frame_index, store.n_obs
    z, largest = store.z, store.largest_area
    E = len(fi)
    d1, unsolvable, empty, ill = np.zeros(E), np.zeros(E, bool), np.zeros(E, bool), np.zeros(E, bool)
    for n in np.unique(counts):
        rows = np.flatnonzero(counts == n)
        try:
            frames = fi[rows][:, observation_indices(int(n), n_obs)]
        except InputError as e:  # as the loaders say it
            raise InputError(f"{store.path}: example {store.example_ids[rows[0]]}: {e}") from None
        sqrt_area = np.sqrt(largest[frames].astype(np.float64))
        dz = z[frames] - z[fi[rows, 0]][:, None]
        d1[rows], unsolvable[rows], ill[rows] = solve(sqrt_area, dz)
        empty[rows] = (largest[frames] == 0).any(axis=1)
    d1[unsolvable] = 0.0
    return BaselineResult(store.attrs.split, store.example_ids, d1, unsolvable, "empty_masks", empty, ill)
