"""Two predictions files compared example by example (`odms-data compare`): per split and per
All, the difference of their mean percent errors (A - B), its 95 % paired cluster-bootstrap
interval and a sign-flip p-value over clusters (bootstrap.py), and which is better where."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import InputError
from .bootstrap import FLIPS, RESAMPLES, flip_statistics, interval, p_value, resampled_means
from .metrics import percent_errors
from .scoring import ScoreReport, sequence_codes

ALPHA = 0.05  # a difference is called when p < ALPHA and its interval excludes 0


@dataclass
class Difference:
    """A - B on one split or one All: the means of each, their difference, its interval and p."""

    name: str
    n: int
    clusters: int
    mean_a: float
    mean_b: float
    ci95: tuple[float, float]
    p_value: float

    @property
    def difference(self) -> float:
        return self.mean_a - self.mean_b

    @property
    def better(self) -> str | None:
        """"A" or "B" (lower error) when the data tell them apart, else None."""
        lo, hi = self.ci95
        if self.p_value >= ALPHA or not lo <= hi or lo <= 0 <= hi:  # NaN bounds: infinite errors
            return None
        return "A" if self.difference < 0 else "B"

    def to_json(self) -> dict:
        return {"name": self.name, "n": self.n, "clusters": self.clusters, "mean_a": self.mean_a,
                "mean_b": self.mean_b, "difference": self.difference, "ci95": list(self.ci95),
                "p_value": self.p_value, "better": self.better}


@dataclass
class Comparison:
    a: str
    b: str
    splits: list[Difference]
    alls: list[Difference]

    def to_json(self) -> dict:
        return {"a": self.a, "b": self.b, "metric": "mean_percent_error", "difference": "A - B",
                "resamples": RESAMPLES, "flips": FLIPS, "alpha": ALPHA,
                "splits": [d.to_json() for d in self.splits], "alls": [d.to_json() for d in self.alls],
                "verdict": verdict(self)}


def _paired(a: ScoreReport, b: ScoreReport) -> None:
    """InputError unless the two reports scored the same examples."""
    for split in sorted(set(a.scored) | set(b.scored)):
        ia = a.scored[split][0] if split in a.scored else np.zeros(0, np.int64)
        ib = b.scored[split][0] if split in b.scored else np.zeros(0, np.int64)
        if len(ia) != len(ib) or not np.array_equal(np.sort(ia), np.sort(ib)):
            raise InputError(f"{a.predictions} and {b.predictions} do not cover the same examples: split "
                             f"{split} has {len(ia)} scored in the first, {len(ib)} in the second; compare "
                             "pairs them example by example")


def all_name(benchmark: str, title: str, family: str) -> str:
    """The name a comparison gives a benchmark's All over `family`."""
    return f"All ({family})" if benchmark == "odms" else f"{title} All ({family})"


def compare(a: ScoreReport, b: ScoreReport) -> Comparison:
    """The paired comparison of two scores of the same examples (InputError otherwise)."""
    _paired(a, b)
    splits, samples, flips = [], {}, {}
    for s in a.scores:
        truth = a.truths[s.split]
        (ia, pa), (ib, pb) = a.scored[s.split], b.scored[s.split]
        oa, ob = np.argsort(ia, kind="stable"), np.argsort(ib, kind="stable")
        idx = ia[oa]
        d1 = truth.d1[idx]
        diffs = percent_errors(pa[oa], d1) - percent_errors(pb[ob], d1)
        codes = sequence_codes(truth, idx)
        samples[s.split] = resampled_means(diffs[None, :], codes, s.split)[0]
        flips[s.split] = flip_statistics(diffs, codes, s.split)
        mb = next(x.mean_percent_error for x in b.scores if x.split == s.split)
        splits.append(Difference(s.split, len(idx), int(codes.max()) + 1, s.mean_percent_error, mb,
                                 interval(samples[s.split]), p_value(float(diffs.mean()), flips[s.split])))
    alls = []
    for x, y in zip(a.alls, b.alls, strict=True):
        observed = x.mean_percent_error - y.mean_percent_error
        parts = [d for d in splits if d.name in x.splits]
        name = all_name(x.benchmark, x.title, x.family)
        alls.append(Difference(
            name, sum(d.n for d in parts), sum(d.clusters for d in parts), x.mean_percent_error,
            y.mean_percent_error, interval(np.mean([samples[sp] for sp in x.splits], axis=0)),
            p_value(observed, np.mean([flips[sp] for sp in x.splits], axis=0))))
    return Comparison(a.predictions, b.predictions, splits, alls)


def verdict(c: Comparison) -> str:
    """Which method is better where, in words, or that the data cannot tell them apart."""
    rows = c.splits + c.alls
    better = {w: [d.name for d in rows if d.better == w] for w in ("A", "B")}
    tie = [d.name for d in rows if d.better is None]
    words = [f"{path} is better on {', '.join(better[w])}"
             for w, path in (("A", c.a), ("B", c.b)) if better[w]]
    if tie:
        words.append(f"the data cannot tell them apart on {', '.join(tie)}")
    text = "; ".join(words)
    if text.startswith("the"):
        text = "T" + text[1:]
    return text + (f". (Better: lower mean percent error, with p < {ALPHA:g} and a 95 % interval of the "
                   "difference that excludes 0.)")


def render_text(c: Comparison) -> str:
    """The comparison as a table (A - B in mean percent error) and the verdict in words."""
    rows = [("split", "n", "clusters", "A mean %", "B mean %", "A - B", "95% CI", "p", "better")]
    for d in c.splits + c.alls:
        rows.append((d.name, str(d.n), str(d.clusters), f"{d.mean_a:.2f}", f"{d.mean_b:.2f}",
                     f"{d.difference:+.2f}", f"[{d.ci95[0]:+.2f}, {d.ci95[1]:+.2f}]", f"{d.p_value:.4f}",
                     d.better or "cannot tell"))
    widths = [max(len(r[i]) for r in rows) for i in range(len(rows[0]))]
    lines = [f"A = {c.a}, B = {c.b}: mean percent error, paired by example; {RESAMPLES} cluster "
             f"bootstrap resamples, {FLIPS} sign flips over clusters"]
    for r in rows:
        cells = [v.rjust(w) for v, w in zip(r[1:], widths[1:], strict=True)]
        lines.append("  ".join([r[0].ljust(widths[0]), *cells]))
    return "\n".join([*lines, verdict(c)]) + "\n"
