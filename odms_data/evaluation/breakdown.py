"""Breakdowns (`score --by KEY`): each split's examples in groups, each group measured by the same
code as the whole split (metrics.score_split, bootstrap.py's intervals).

The keys: `depth` (true d1 in the bins of the split's benchmark record), `motion` (the camera's
travel over the example, likewise), `window` (frames the example spans: the robot protocol's
10 to 30), `object` (what the benchmark's sources name: ODMS's robot objects), `sequence` (the
recorded sequence: a robot approach, a SYNTHIA sequence, a recording) and `n-obs`. A split of no
benchmark is cut at the quintiles of its own depths or motions.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..protocol import benchmark_of, object_of, sequence_of
from .bootstrap import interval, resampled_means
from .ground_truth import SplitTruth
from .metrics import SplitScore, from_means, score_split, term_matrix
from .scoring import ScoreReport, sequence_codes

KEYS = ("depth", "motion", "window", "object", "sequence", "n-obs")
NONE = "(none)"  # the group of examples the key says nothing of (no object, no recorded sequence)


@dataclass
class GroupScore:
    split: str
    group: str
    score: SplitScore

    def to_json(self) -> dict:
        s = self.score
        return {"split": self.split, "group": self.group, "n": s.n,
                "mean_percent_error": s.mean_percent_error, "median_percent_error": s.median_percent_error,
                "mean_abs_error_m": s.mean_abs_error_m, "metrics": s.metrics, "ci95": s.ci95}


def _edges(truth: SplitTruth, key: str, values: np.ndarray) -> np.ndarray:
    found = benchmark_of(truth.split, truth.domain)
    if found:
        b, d, _ = found
        return np.array(b.depth_bins[d] if key == "depth" else b.motion_bins[d])
    inner = np.unique(np.quantile(values, [0.2, 0.4, 0.6, 0.8])) if len(values) else np.zeros(0)
    return np.concatenate([[-np.inf], inner, [np.inf]])


def _binned(truth: SplitTruth, key: str, values: np.ndarray) -> tuple[np.ndarray, list[str]]:
    edges = _edges(truth, key, values)
    which = np.clip(np.searchsorted(edges, values, side="right") - 1, 0, len(edges) - 2)
    names = [f"[{lo:g}, {hi:g}) m" for lo, hi in zip(edges[:-1], edges[1:], strict=True)]
    return which, names


def groups_of(truth: SplitTruth, idx: np.ndarray, key: str) -> tuple[np.ndarray, list[str]]:
    """(group number of each example `idx` of `truth`, the groups' names in order)."""
    if key in ("depth", "motion"):
        return _binned(truth, key, (truth.d1 if key == "depth" else truth.motion)[idx])
    if key in ("window", "n-obs"):
        values = (truth.window if key == "window" else truth.n_obs)[idx]
        distinct = np.unique(values)
        names = [f"{v} frames" if key == "window" else f"n = {v}" for v in distinct]
        return np.searchsorted(distinct, values), names
    sources = truth.sources or [""] * len(truth.example_ids)
    name = object_of if key == "object" else sequence_of
    labels = [name(truth.split, truth.domain, sources[i]) or NONE for i in idx.tolist()]
    order = sorted(set(labels))
    number = {g: k for k, g in enumerate(order)}
    return np.array([number[g] for g in labels], np.int64), order


def breakdown(report: ScoreReport, key: str, *, intervals: bool = True) -> list[GroupScore]:
    """Every split's groups by `key`, each scored as a split is (empty groups left out)."""
    out = []
    for s in report.scores:
        truth = report.truths[s.split]
        idx, pred = report.scored[s.split]
        which, names = groups_of(truth, idx, key)
        for g, name in enumerate(names):
            sel = which == g
            if not sel.any():
                continue
            score = score_split(s.split, s.domain, pred[sel], truth.d1[idx[sel]], int(sel.sum()))
            codes = sequence_codes(truth, idx[sel])
            if intervals and codes.max() > 0:
                terms = term_matrix(pred[sel], truth.d1[idx[sel]])
                samples = from_means(resampled_means(terms, codes, f"{s.split} {key} {name}"))
                score.ci95 = {m: interval(v) for m, v in samples.items()}
            out.append(GroupScore(s.split, name, score))
    return out
