"""Batched least squares through the normal equations, as both baselines' authors solve them
(VOS-DE, Box_LS): LAPACK on A^T A x = A^T b, a singular A^T A marking the system unsolvable."""

from __future__ import annotations

import numpy as np


def first_unknown(A: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """For systems A (E, m, u) and b (E, m): the first unknown of each least-squares solution
    (0 where unsolvable) and which systems are unsolvable."""
    At = A.swapaxes(1, 2)
    AtA, Atb = At @ A, At @ b[..., None]
    x, bad = np.zeros(len(A)), np.zeros(len(A), bool)
    try:
        return np.linalg.solve(AtA, Atb)[:, 0, 0], bad
    except np.linalg.LinAlgError:
        pass  # at least one singular system: solve one by one to find which
    for i in range(len(A)):
        try:
            x[i] = np.linalg.solve(AtA[i], Atb[i])[0, 0]
        except np.linalg.LinAlgError:
            bad[i] = True
    return x, bad
