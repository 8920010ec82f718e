"""The ODMS metrics, as pure functions of aligned prediction and label arrays (metres).

Per split: n, mean percent error `|d1 - d1_hat| / d1 * 100`, median percent error and mean
absolute error. "All" of a family (val or test) is the unweighted mean of the robot, driving,
normal and perturb mean percent errors, given only when all four are scored in full.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import StoreError
from ..protocol import ABS_UNITS, FAMILIES, OFFICIAL_DOMAINS, official_name


def percent_errors(pred: np.ndarray, truth: np.ndarray) -> np.ndarray:
    """|truth - pred| / truth * 100, elementwise (infinite, without a warning, where that overflows)."""
    with np.errstate(over="ignore"):
        return np.abs(truth - pred) / truth * 100.0


@dataclass
class SplitScore:
    split: str
    domain: str
    n: int  # examples scored
    total: int  # labelled examples in the split
    mean_percent_error: float
    median_percent_error: float
    mean_abs_error_m: float

    @property
    def partial(self) -> bool:
        return self.n < self.total

    @property
    def abs_unit(self) -> str:
        """The unit the paper prints absolute errors in: m for driving, cm otherwise."""
        return ABS_UNITS.get(self.domain, "cm")

    @property
    def mean_abs_error(self) -> float:
        """Mean absolute error in `abs_unit`."""
        return self.mean_abs_error_m * (1.0 if self.abs_unit == "m" else 100.0)


def score_split(split: str, domain: str, pred: np.ndarray, truth: np.ndarray, total: int) -> SplitScore:
    """Metrics of one split from aligned prediction and label arrays (metres)."""
    pred, truth = np.asarray(pred, np.float64), np.asarray(truth, np.float64)
    if (truth <= 0).any():
        raise StoreError(f"split {split}: labels must be positive depths, found {truth.min()}")
    with np.errstate(over="ignore"):  # absurd predictions (1e308 m) give infinite errors, no warning
        pe = percent_errors(pred, truth)
        return SplitScore(
            split=split, domain=domain, n=len(pe), total=total,
            mean_percent_error=float(pe.mean()), median_percent_error=float(np.median(pe)),
            mean_abs_error_m=float(np.abs(truth - pred).mean()),
        )


def all_by_family(scores: list[SplitScore]) -> dict[str, float]:
    """{family: All} for each family whose four official splits are all scored in full."""
    full = {official_name(s.split, s.domain): s for s in scores if not s.partial}
    out = {}
    for fam in FAMILIES:
        parts = [full[(d, fam)] for d in OFFICIAL_DOMAINS if (d, fam) in full]
        if len(parts) == len(OFFICIAL_DOMAINS):
            out[fam] = float(np.mean([p.mean_percent_error for p in parts]))
    return out
