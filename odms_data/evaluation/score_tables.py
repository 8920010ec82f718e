"""Rendering a ScoreReport: a plain-text table (the default) or markdown."""

from __future__ import annotations

from ..protocol import BENCHMARKS
from .breakdown import GroupScore
from .metrics import METRICS, AllScore, SplitScore
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


# the metrics' column heads, in METRICS' order; shares are fractions, percentiles in percent
METRIC_HEADS = {
    "abs_rel": "AbsRel", "sq_rel": "SqRel", "rmse": "RMSE m", "rmse_log": "RMSE log", "delta1": "d<1.25",
    "delta2": "d<1.25^2", "delta3": "d<1.25^3", "within_5": "<=5%", "within_10": "<=10%",
    "within_25": "<=25%",
    "p90_percent": "p90 %", "p95_percent": "p95 %",
}


def _ci(ci95: dict, key: str) -> str:
    lo, hi = ci95.get(key, (None, None))
    return "" if lo is None else f"[{lo:.2f}, {hi:.2f}]"


def _head(metrics: bool, ci: bool) -> list[str]:
    return ["n", "mean %", *(["95% CI"] if ci else []), "median %", "mean abs error",
            *([METRIC_HEADS[m] for m in METRICS] if metrics else [])]


def _cells(s: SplitScore, metrics: bool, ci: bool) -> list[str]:
    """One split's (or group's) cells under _head."""
    n = f"{s.n}/{s.total}" if s.partial else str(s.n)
    return [n, f"{s.mean_percent_error:.2f}", *([_ci(s.ci95, "mean_percent_error")] if ci else []),
            f"{s.median_percent_error:.2f}", f"{s.mean_abs_error:.2f} {s.abs_unit}",
            *([f"{s.metrics[m]:.3f}" for m in METRICS] if metrics else [])]


def _table(report: ScoreReport, metrics: bool, ci: bool) -> list[list[str]]:
    """The table's rows, its head first: per split, then (with metrics or ci) per All."""
    rows = [["split", *_head(metrics, ci)]]
    rows += [[s.split, *_cells(s, metrics, ci)] for s in report.scores]
    for a in report.alls if metrics or ci else ():
        interval = [_ci(a.ci95, "mean_percent_error")] if ci else []
        rows.append([_all_name(a), "", f"{a.mean_percent_error:.2f}", *interval, "", "",
                     *([f"{a.metrics[m]:.3f}" for m in METRICS] if metrics else [])])
    return rows


def _aligned(rows: list[list[str]], left: int = 1) -> list[str]:
    """Rows as text columns: the first `left` left-aligned, the others right-aligned."""
    widths = [max(len(r[i]) for r in rows) for i in range(len(rows[0]))]
    return ["  ".join([c.ljust(w) if i < left else c.rjust(w) for i, (c, w) in enumerate(zip(r, widths,
                                                                                         strict=True))]).rstrip()
            for r in rows]


def breakdown_rows(groups: list[GroupScore], key: str, metrics: bool, ci: bool) -> list[list[str]]:
    """The rows of a breakdown by `key`, its head first."""
    return [["split", key, *_head(metrics, ci)]] + [[g.split, g.group, *_cells(g.score, metrics, ci)]
                                                     for g in groups]


def breakdown_text(groups: list[GroupScore], key: str, *, metrics: bool = False, ci: bool = False) -> str:
    return "\n".join([f"by {key}:", *_aligned(breakdown_rows(groups, key, metrics, ci), left=2)]) + "\n"


def breakdown_markdown(groups: list[GroupScore], key: str, *, metrics: bool = False, ci: bool = False) -> str:
    rows = breakdown_rows(groups, key, metrics, ci)
    lines = [f"By {key}:", "", "| " + " | ".join(rows[0]) + " |", "|---|---|" + "---:|" * (len(rows[0]) - 2)]
    return "\n".join([*lines, *("| " + " | ".join(r) + " |" for r in rows[1:])]) + "\n"


def render_text(report: ScoreReport, *, metrics: bool = False, ci: bool = False) -> str:
    """The plain-text table; `metrics` adds the depth metrics' columns, `ci` the 95 % interval of
    each mean percent error (both add a row per All)."""
    lines = _banner(report) + [f"{report.predictions}: {report.rows} predictions"]
    lines += _aligned(_table(report, metrics, ci))
    return "\n".join(lines + _footer(report) + _banner(report)) + "\n"


def report_markdown(report: ScoreReport, *, metrics: bool = False, ci: bool = False) -> str:
    """The table in markdown, with a bold row per All."""
    lines = [f"> {b.lstrip('! ')}" for b in _banner(report)]
    rows = _table(report, metrics, ci)
    head = [h.replace("mean %", "mean % error").replace("median %", "median % error") for h in rows[0]]
    lines += ["| " + " | ".join(head) + " |", "|---|" + "---:|" * (len(head) - 1)]
    lines += ["| " + " | ".join(r) + " |" for r in rows[1:len(report.scores) + 1]]
    extra = rows[len(report.scores) + 1:] or [["", "", "", "", ""]] * len(report.alls)
    for a, r in zip(report.alls, extra, strict=True):
        cells = r[3:]
        lines.append(f"| **{_all_name(a)}** | | **{a.mean_percent_error:.2f}** |"
                     + "".join(f" {c} |" if c else " |" for c in cells))
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
