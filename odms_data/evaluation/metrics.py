"""The ODMS metrics, as pure functions of aligned prediction and label arrays (metres).

Per split: n, mean percent error `|d1 - d1_hat| / d1 * 100`, median percent error and mean
absolute error. A benchmark's "All" of a family (val or test) is formed as its record in
protocol.py says (the unweighted mean of its sets' means), given only when every one of its sets
is scored in full.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import StoreError
from ..protocol import BENCHMARKS, SPLIT_FAMILIES, benchmark_of


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
        """The unit the benchmark's paper prints absolute errors in (ODMS: m for driving); a split
        of no benchmark takes its domain's unit in ODMS (cm when ODMS has no such domain)."""
        found = benchmark_of(self.split, self.domain)
        return found[0].units[found[1]] if found else BENCHMARKS["odms"].units.get(self.domain, "cm")

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


@dataclass
class AllScore:
    """A benchmark's All over one family: its sets' splits and the figure its record's rule gives."""

    benchmark: str  # the record's key in protocol.BENCHMARKS
    family: str
    splits: tuple[str, ...]
    mean_percent_error: float

    @property
    def title(self) -> str:
        return BENCHMARKS[self.benchmark].title


def all_scores(scores: list[SplitScore]) -> list[AllScore]:
    """Every benchmark's All for each family whose sets are all scored in full."""
    full: dict[tuple[str, str], dict[str, SplitScore]] = {}
    for s in scores:
        found = benchmark_of(s.split, s.domain)
        if found and not s.partial:
            full.setdefault((found[0].key, found[2]), {})[found[1]] = s
    out = []
    for key, b in BENCHMARKS.items():
        for fam in SPLIT_FAMILIES:
            sets = full.get((key, fam), {})
            value = b.all_of({d: s.mean_percent_error for d, s in sets.items()})
            if value is not None:
                out.append(AllScore(key, fam, tuple(sets[d].split for d in b.all_sets), value))
    return out


def all_by_family(scores: list[SplitScore]) -> dict[str, float]:
    """{family: All} of ODMS, for each family whose four splits are all scored in full."""
    return {a.family: a.mean_percent_error for a in all_scores(scores) if a.benchmark == "odms"}
