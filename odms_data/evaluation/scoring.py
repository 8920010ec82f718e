"""The score of a predictions file against the ground truth: every split it covers, checked
first (predictions.check_against), then measured (metrics.py)."""

from __future__ import annotations

from dataclasses import asdict, dataclass, field

import numpy as np

from ..protocol import split_order
from .ground_truth import SplitTruth
from .metrics import AllScore, SplitScore, all_scores, percent_errors, score_split
from .predictions import Predictions, check_against


@dataclass
class ScoreReport:
    """What `odms-data score` reports for one predictions file."""

    predictions: str
    rows: int
    scores: list[SplitScore]
    alls: list[AllScore]  # every benchmark's All whose sets are all scored in full
    partial: bool
    unlabelled_ignored: int = 0
    digests: dict[str, str] = field(default_factory=dict)  # split -> store digest
    errors: dict[str, tuple[np.ndarray, np.ndarray]] = field(default_factory=dict, repr=False)

    @property
    def all(self) -> dict[str, float]:
        """ODMS's All by family (the `all` of the JSON report)."""
        return {a.family: a.mean_percent_error for a in self.alls if a.benchmark == "odms"}

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
            "benchmark_alls": [
                {"benchmark": a.benchmark, "title": a.title, "family": a.family, "splits": list(a.splits),
                 "mean_percent_error": a.mean_percent_error}
                for a in self.alls
            ],
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
        predictions=preds.path, rows=len(f), scores=scores, alls=all_scores(scores),
        partial=any(s.partial for s in scores), unlabelled_ignored=ignored,
        digests={s.split: truths[s.split].digest for s in scores}, errors=errors,
    )
