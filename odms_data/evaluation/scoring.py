"""The ODMS metrics and the score of a predictions file against the ground truth.

Per split: n, mean percent error `|d1 - d1_hat| / d1 * 100`, median percent error and mean
absolute error (m). "All" of a family (val or test) is the unweighted mean of the robot,
driving, normal and perturb mean percent errors, given only when all four are scored in full.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field

import numpy as np

from ..benchmark import ABS_UNITS, FAMILIES, OFFICIAL_DOMAINS, official_name, split_order
from ..errors import StoreError
from .ground_truth import SplitTruth
from .predictions import Predictions, check_against


def percent_errors(pred: np.ndarray, truth: np.ndarray) -> np.ndarray:
    """|truth - pred| / truth * 100, elementwise."""
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
    pe = percent_errors(pred, truth)
    return SplitScore(
        split=split, domain=domain, n=len(pe), total=total,
        mean_percent_error=float(pe.mean()), median_percent_error=float(np.median(pe)),
        mean_abs_error_m=float(np.abs(truth - pred).mean()),
    )


def family_all(scores: list[SplitScore]) -> dict[str, float]:
    """{family: All} for each family whose four official splits are all scored in full."""
    full = {official_name(s.split, s.domain): s for s in scores if not s.partial}
    out = {}
    for fam in FAMILIES:
        parts = [full.get((d, fam)) for d in OFFICIAL_DOMAINS]
        if all(parts):
            out[fam] = float(np.mean([p.mean_percent_error for p in parts]))
    return out


@dataclass
class ScoreReport:
    """What `odms-data score` reports for one predictions file."""

    predictions: str
    rows: int
    scores: list[SplitScore]
    all: dict[str, float]
    partial: bool
    unlabelled_ignored: int = 0
    digests: dict[str, str] = field(default_factory=dict)  # split -> store digest
    errors: dict[str, tuple[np.ndarray, np.ndarray]] = field(default_factory=dict, repr=False)

    def to_json(self) -> dict:
        return {
            "predictions": self.predictions, "rows": self.rows, "partial": self.partial,
            "unlabelled_ignored": self.unlabelled_ignored,
            "splits": [
                {**asdict(s), "partial": s.partial, "abs_unit": s.abs_unit,
                 "mean_abs_error": s.mean_abs_error, "store_digest": self.digests.get(s.split)}
                for s in self.scores
            ],
            "all": self.all,
        }


def score(preds: Predictions, truths: dict[str, SplitTruth], *, allow_partial: bool = False) -> ScoreReport:
    """Check `preds` against `truths` (which must cover its splits) and score every split in it.

    Predictions for unlabelled examples are allowed and ignored (their count is reported).
    """
    labelled = {s: t.labelled_ids for s, t in truths.items()}
    ids = {s: t.example_ids for s, t in truths.items()}
    missing = check_against(preds, ids, labelled, allow_partial=allow_partial)
    f = preds.frame
    scores, errors, ignored = [], {}, 0
    for split in sorted(missing, key=split_order):
        t = truths[split]
        rows = f[f["split"] == split]
        index = {e: i for i, e in enumerate(t.example_ids)}
        idx = np.array([index[e] for e in rows["example_id"].tolist()], np.int64)
        truth = t.d1[idx]
        keep = ~np.isnan(truth)
        ignored += int((~keep).sum())
        if not keep.any():
            continue
        pred = rows["d1"].to_numpy(np.float64)[keep]
        s = score_split(split, t.domain, pred, truth[keep], len(labelled[split]))
        scores.append(s)
        errors[split] = (truth[keep], percent_errors(pred, truth[keep]))
    return ScoreReport(
        predictions=preds.path, rows=len(f), scores=scores, all=family_all(scores),
        partial=any(s.partial for s in scores), unlabelled_ignored=ignored,
        digests={s.split: truths[s.split].digest for s in scores}, errors=errors,
    )
