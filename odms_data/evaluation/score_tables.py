"""Rendering a ScoreReport: a plain-text table (the default) or markdown."""

from __future__ import annotations

from ..protocol import FAMILIES
from .scoring import ScoreReport


def _banner(report: ScoreReport) -> list[str]:
    if not report.partial:
        return []
    parts = [f"{s.split} {s.n}/{s.total}" for s in report.scores if s.partial]
    return [
        "!!! PARTIAL SCORE (--allow-partial): only a subset of examples was scored "
        f"({', '.join(parts)}).",
        "!!! These figures are NOT comparable with the leaderboard; "
        "no All is given for an incomplete family.",
    ]


def _footer(report: ScoreReport) -> list[str]:
    out = [f"All ({fam}) = {report.all[fam]:.2f}  (mean of robot, driving, normal, perturb percent errors)"
           for fam in FAMILIES if fam in report.all]
    if report.unlabelled_ignored:
        out.append(f"{report.unlabelled_ignored} predictions for unlabelled examples were ignored")
    return out


def render_text(report: ScoreReport) -> str:
    rows = [("split", "n", "mean %", "median %", "mean abs error")]
    for s in report.scores:
        n = f"{s.n}/{s.total}" if s.partial else str(s.n)
        rows.append((s.split, n, f"{s.mean_percent_error:.2f}", f"{s.median_percent_error:.2f}",
                     f"{s.mean_abs_error:.2f} {s.abs_unit}"))
    widths = [max(len(r[i]) for r in rows) for i in range(5)]
    lines = _banner(report) + [f"{report.predictions}: {report.rows} predictions"]
    for r in rows:
        lines.append("  ".join([r[0].ljust(widths[0])] + [c.rjust(w) for c, w in zip(r[1:], widths[1:],
                                                                                     strict=True)]))
    return "\n".join(lines + _footer(report) + _banner(report)) + "\n"


def report_markdown(report: ScoreReport) -> str:
    lines = [f"> {b.lstrip('! ')}" for b in _banner(report)]
    lines += ["| split | n | mean % error | median % error | mean abs error |", "|---|---:|---:|---:|---:|"]
    for s in report.scores:
        n = f"{s.n}/{s.total}" if s.partial else str(s.n)
        lines.append(f"| {s.split} | {n} | {s.mean_percent_error:.2f} | {s.median_percent_error:.2f} | "
                     f"{s.mean_abs_error:.2f} {s.abs_unit} |")
    for fam in FAMILIES:
        if fam in report.all:
            lines.append(f"| **All ({fam})** | | **{report.all[fam]:.2f}** | | |")
    if report.unlabelled_ignored:
        lines += ["", f"{report.unlabelled_ignored} predictions for unlabelled examples were ignored."]
    return "\n".join(lines) + "\n"
