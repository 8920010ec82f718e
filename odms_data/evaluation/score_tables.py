"""Rendering a ScoreReport: a plain-text table (the default) or markdown."""

from __future__ import annotations

from ..protocol import BENCHMARKS
from .metrics import AllScore
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


def _all_name(a: AllScore) -> str:
    """ODMS's All keeps its name, "All (test)"; another benchmark's says whose it is."""
    return f"All ({a.family})" if a.benchmark == "odms" else f"{a.title} All ({a.family})"


def _footer(report: ScoreReport) -> list[str]:
    out = [f"{_all_name(a)} = {a.mean_percent_error:.2f}  "
           f"(mean of {', '.join(BENCHMARKS[a.benchmark].all_sets)} percent errors)" for a in report.alls]
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
    for a in report.alls:
        lines.append(f"| **{_all_name(a)}** | | **{a.mean_percent_error:.2f}** | | |")
    if report.unlabelled_ignored:
        lines += ["", f"{report.unlabelled_ignored} predictions for unlabelled examples were ignored."]
    return "\n".join(lines) + "\n"


def benchmarks_markdown() -> str:
    """The benchmarks' records (protocol.BENCHMARKS) as markdown tables: docs/SCORING.md shows them."""
    lines = []
    for b in BENCHMARKS.values():
        lines += [f"**{b.title}** (`{b.key}`): All = the mean of the {len(b.all_sets)} per-set means; "
                  f"published baselines: {', '.join(b.baselines)}.", "",
                  "| set | val split | n | test split | n | abs. error in | depth bins (m) "
                  "| motion bins (m) |",
                  "|---|---|---:|---|---:|---|---|---|"]
        for d in b.domains:
            val, test = b.split(d, "val"), b.split(d, "test")
            bins = [", ".join(f"{e:g}" for e in edges) for edges in (b.depth_bins[d], b.motion_bins[d])]
            lines.append(f"| {d} | {val} | {b.counts[val]:,} | {test} | {b.counts[test]:,} | {b.units[d]} | "
                         f"{bins[0]} | {bins[1]} |")
        lines.append("")
    return "\n".join(lines)
