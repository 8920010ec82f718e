"""Batched least squares through the normal equations, as both baselines' authors solve them
(VOS-DE, Box_LS): LAPACK on A^T A x = A^T b, a singular A^T A marking the system unsolvable, as
does one whose numbers overflow (a box 1e160 wide): no floating-point warning, a counted row.

A system LAPACK solves although A^T A's condition number passes 1 / eps (about 4.5e15) is
*ill-conditioned*: its answer, kept as the authors' code gives it, has no significant digit left
and moves with the maths library (ODMD's robot test has four examples with one detection in ten,
A^T A singular but for rounding: LAPACK refuses two and answers the others with rounding noise).
Well-posed systems on the official and ODMD sets stay below 1e8."""

from __future__ import annotations

import numpy as np

CONDITION_LIMIT = 1 / np.finfo(np.float64).eps


def unmoved(positions: np.ndarray) -> np.ndarray:
    """Which of the (E, k) rows of camera positions (or movements) never move: their least-squares
    system has no depth to find, whatever it solves to (0 m), so they count as unsolvable."""
    return np.ptp(positions, axis=1) == 0 if positions.size else np.zeros(len(positions), bool)


def first_unknown(A: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """For systems A (E, m, u) and b (E, m): the first unknown of each least-squares solution
    (0 where unsolvable), which systems are unsolvable and which solved ones ill-conditioned."""
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
        cond = np.linalg.cond(AtA) if len(A) else np.zeros(0)
    return np.where(bad, 0.0, x), bad, ~bad & ~(cond <= CONDITION_LIMIT)
