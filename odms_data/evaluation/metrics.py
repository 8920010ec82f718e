"""The ODMS metrics, as pure functions of aligned prediction and label arrays (metres).

Per split: n, mean percent error `|d1 - d1_hat| / d1 * 100` (the headline), median percent error
and mean absolute error; beside them the depth metrics of Eigen et al. (AbsRel, SqRel, RMSE, RMSE
log, the shares within δ < 1.25, 1.25², 1.25³), the shares within 5, 10 and 25 % error and the
90th and 95th percentiles of percent error, each defined once here (formulas: docs/SCORING.md).
Every metric but the percentiles is a function of the mean of a per-example term (`TERMS`), so
that a resample of examples (bootstrap.py) recomputes them all from one matrix. A benchmark's
"All" of a family (val or test) is formed as its record in protocol.py says (the unweighted
mean of its sets' means; each metric's All likewise), given only when every one of its sets is
scored in full.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..errors import StoreError
from ..protocol import BENCHMARKS, SPLIT_FAMILIES, benchmark_of


def percent_errors(pred: np.ndarray, truth: np.ndarray) -> np.ndarray:
    """|truth - pred| / truth * 100, elementwise (infinite, without a warning, where that overflows)."""
    with np.errstate(over="ignore"):
        return np.abs(truth - pred) / truth * 100.0


LOG_FLOOR_M = 1e-3  # a prediction below 1 mm counts as 1 mm in RMSE log and the δ ratios
DELTAS = (1.25, 1.25**2, 1.25**3)
WITHIN = (5.0, 10.0, 25.0)  # percent error thresholds, each included
PERCENTILES = (90.0, 95.0)  # of percent error, numpy's linear interpolation


def _terms(pred: np.ndarray, truth: np.ndarray) -> dict[str, np.ndarray]:
    """The per-example term of every mean-based metric (a name ending in "^2" is the mean of
    squares whose root is the metric)."""
    with np.errstate(over="ignore", invalid="ignore"):
        err = truth - pred
        pe = np.abs(err) / truth * 100.0
        floored = np.maximum(pred, LOG_FLOOR_M)
        ratio = np.maximum(truth / floored, floored / truth)
        return {
            "mean_percent_error": pe, "mean_abs_error_m": np.abs(err), "abs_rel": np.abs(err) / truth,
            "sq_rel": err * err / truth, "rmse^2": err * err,
            "rmse_log^2": (np.log(truth) - np.log(floored)) ** 2,
            **{f"delta{k}": (ratio < t).astype(np.float64) for k, t in enumerate(DELTAS, 1)},
            **{f"within_{w:g}": (pe <= w).astype(np.float64) for w in WITHIN},
        }


TERMS = tuple(_terms(np.ones(1), np.ones(1)))  # the names, in order


def term_matrix(pred: np.ndarray, truth: np.ndarray) -> np.ndarray:
    """(len(TERMS), n) C-ordered: row k holds term k of every example."""
    t = _terms(np.asarray(pred, np.float64), np.asarray(truth, np.float64))
    return np.stack([t[name] for name in TERMS])


def from_means(means: np.ndarray) -> dict[str, np.ndarray]:
    """The metrics from the means of the terms (axis 0 indexes TERMS; any trailing shape)."""
    out = {}
    for name, m in zip(TERMS, means, strict=True):
        if name.endswith("^2"):
            out[name[:-2]] = np.sqrt(m)
        else:
            out[name] = m
    return out


def depth_metrics(pred: np.ndarray, truth: np.ndarray) -> dict[str, float]:
    """Every metric but the headline three: AbsRel, SqRel, RMSE, RMSE log, δ1-3, the shares within
    5/10/25 % and the 90th/95th percentiles of percent error."""
    m = term_matrix(pred, truth)
    values = {k: float(v) for k, v in from_means(m.mean(axis=1)).items()
              if k not in ("mean_percent_error", "mean_abs_error_m")}
    with np.errstate(invalid="ignore", over="ignore"):  # of infinite errors
        return values | {f"p{q:g}_percent": float(np.percentile(m[0], q)) for q in PERCENTILES}


METRICS = tuple(depth_metrics(np.ones(1), np.ones(1)))  # the names of the metrics beside the headline


@dataclass
class SplitScore:
    split: str
    domain: str
    n: int  # examples scored
    total: int  # labelled examples in the split
    mean_percent_error: float
    median_percent_error: float
    mean_abs_error_m: float
    metrics: dict[str, float] = field(default_factory=dict)  # depth_metrics
    ci95: dict[str, tuple[float, float]] = field(default_factory=dict)  # mean-based metrics' intervals

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
            mean_abs_error_m=float(np.abs(truth - pred).mean()), metrics=depth_metrics(pred, truth),
        )


@dataclass
class AllScore:
    """A benchmark's All over one family: its sets' splits and the figure its record's rule gives."""

    benchmark: str  # the record's key in protocol.BENCHMARKS
    family: str
    splits: tuple[str, ...]
    mean_percent_error: float
    metrics: dict[str, float] = field(default_factory=dict)  # each metric's All, by the same rule
    ci95: dict[str, tuple[float, float]] = field(default_factory=dict)  # their intervals

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
                metrics = {m: b.all_of({d: s.metrics[m] for d, s in sets.items() if m in s.metrics})
                           for m in METRICS}
                out.append(AllScore(key, fam, tuple(sets[d].split for d in b.all_sets), value,
                                    {m: v for m, v in metrics.items() if v is not None}))
    return out


def all_by_family(scores: list[SplitScore]) -> dict[str, float]:
    """{family: All} of ODMS, for each family whose four splits are all scored in full."""
    return {a.family: a.mean_percent_error for a in all_scores(scores) if a.benchmark == "odms"}
