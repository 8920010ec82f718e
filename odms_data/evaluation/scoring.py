"""The score of a predictions file against the ground truth: every split it covers, checked
first (predictions.check_against), then measured (metrics.py), each mean and All with its 95 %
cluster-bootstrap interval (bootstrap.py)."""

from __future__ import annotations

from dataclasses import asdict, dataclass, field

import numpy as np

from ..protocol import sequence_of, split_order
from .bootstrap import RESAMPLES, cluster_codes, interval, resampled_means
from .ground_truth import SplitTruth
from .metrics import AllScore, SplitScore, all_scores, from_means, percent_errors, score_split, term_matrix
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
    # split -> (indices of the scored examples in its truth, their predictions), and the truths
    scored: dict[str, tuple[np.ndarray, np.ndarray]] = field(default_factory=dict, repr=False)
    truths: dict[str, SplitTruth] = field(default_factory=dict, repr=False)
    resamples: int = 0  # of the intervals (0: none computed)

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
                 "mean_percent_error": a.mean_percent_error, "metrics": a.metrics, "ci95": a.ci95}
                for a in self.alls
            ],
            "intervals": {"level": 0.95, "resamples": self.resamples, "method": "cluster bootstrap over "
                          "recorded sequences, seeded (docs/SCORING.md)"},
        }


def score(preds: Predictions, truths: dict[str, SplitTruth], *, allow_partial: bool = False,
          intervals: bool = True) -> ScoreReport:
    """Check `preds` against `truths` (which must cover its splits) and score every split in it,
    with the 95 % interval of every mean and All unless `intervals` is False.

    Predictions for unlabelled examples are allowed and ignored (their count is reported).
    """
    labelled = {s: t.labelled_ids for s, t in truths.items()}
    ids = {s: t.example_ids for s, t in truths.items()}
    missing = check_against(preds, ids, labelled, allow_partial=allow_partial)
    f = preds.frame
    scores, errors, scored, samples, ignored = [], {}, {}, {}, 0
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
        scored[split] = (idx[keep], pred)
        codes = sequence_codes(t, idx[keep])
        if intervals and codes.max() > 0:  # one recorded sequence alone gives no interval
            samples[split] = from_means(resampled_means(term_matrix(pred, truth[keep]), codes, split))
            s.ci95 = {m: interval(v) for m, v in samples[split].items()}
    alls = all_scores(scores)
    for a in alls if intervals else ():
        sets = [samples[split] for split in a.splits if split in samples]
        if len(sets) < len(a.splits):
            continue
        a.ci95 = {m: interval(np.mean([v[m] for v in sets], axis=0))
                  for m in sets[0] if m != "mean_abs_error_m"}  # absolute errors of sets in m and cm
    return ScoreReport(
        predictions=preds.path, rows=len(f), scores=scores, alls=alls,
        partial=any(s.partial for s in scores), unlabelled_ignored=ignored,
        digests={s.split: truths[s.split].digest for s in scores}, errors=errors, scored=scored,
        truths={split: truths[split] for split in scored}, resamples=RESAMPLES if intervals else 0,
    )


def sequence_codes(truth: SplitTruth, idx: np.ndarray) -> np.ndarray:
    """The cluster of each of the examples `idx` of `truth`: its recorded sequence, or itself."""
    sources = truth.sources or [""] * len(truth.example_ids)
    return cluster_codes([sequence_of(truth.split, truth.domain, sources[i]) for i in idx.tolist()])
