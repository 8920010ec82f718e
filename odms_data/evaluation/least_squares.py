"""Batched least squares through the normal equations, as both baselines' authors solve them
(VOS-DE, Box_LS): LAPACK on A^T A x = A^T b, a singular A^T A marking the system unsolvable, as
does one whose numbers overflow (a box 1e160 wide): no floating-point warning, a counted row."""

from __future__ import annotations

import numpy as np


def unmoved(positions: np.ndarray) -> np.ndarray:
    """Which of the (E, k) rows of camera positions (or movements) never move: their least-squares
    system has no depth to find, whatever it solves to (0 m), so they count as unsolvable."""
    return np.ptp(positions, axis=1) == 0 if positions.size else np.zeros(len(positions), bool)


def first_unknown(A: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """For systems A (E, m, u) and b (E, m): the first unknown of each least-squares solution
    (0 where unsolvable) and which systems are unsolvable."""
    with np.errstate(all="ignore"):
        At = A.swapaxes(1, 2)
        AtA, Atb = At @ A, At @ b[..., None]
        bad = ~(np.isfinite(AtA).all(axis=(1, 2)) & np.isfinite(Atb).all(axis=(1, 2)))
        AtA[bad], Atb[bad] = np.eye(A.shape[2]), 0.0  # solved as 0, counted unsolvable
        x = np.zeros(len(A))
        try:
            x = np.linalg.solve(AtA, Atb)[:, 0, 0]
        except np.linalg.LinAlgError:  # at least one singular system: solve one by one to find which
            for i in range(len(A)):
                try:
                    x[i] = np.linalg.solve(AtA[i], Atb[i])[0, 0]
                except np.linalg.LinAlgError:
                    bad[i] = True
        bad |= ~np.isfinite(x)
    return np.where(bad, 0.0, x), bad
