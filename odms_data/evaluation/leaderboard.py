"""The leaderboard: one JSON entry per method in leaderboard/ (schemas/leaderboard-entry.schema.json).

Entries are either *published* (figures as printed in the cited work) or *computed* (scored by
odms-data from a predictions file, with the store digests they were scored against). Each is on
one benchmark (BENCHMARKS): ODMS (the default) or ODMD, whose sets are ODMD's own four.
"""

from __future__ import annotations

import datetime
import difflib
import hashlib
import json
import math
from dataclasses import dataclass
from functools import cache
from pathlib import Path
from typing import Any

from .. import safe_json
from .._version import __version__
from ..errors import InputError
from ..protocol import BENCHMARKS as PROTOCOL_BENCHMARKS
from ..protocol import SPLIT_FAMILIES
from ..resources import resource_dir
from ..shown_text import markdown_link, markdown_text
from .scoring import ScoreReport

# the benchmarks with a table of their own (protocol.py's records); ODMS-detection's figures sit
# in ODMS's table
BENCHMARKS = {k: PROTOCOL_BENCHMARKS[k] for k in ("odms", "odmd")}


@cache
def _validator():
    import jsonschema

    schema = json.loads((resource_dir("schemas") / "leaderboard-entry.schema.json").read_text())
    return jsonschema.Draft202012Validator(schema)


def entry_problems(entry: Any) -> list[str]:
    """Every way `entry` breaks the entry schema, one line each."""
    errors = sorted(_validator().iter_errors(entry), key=lambda e: list(e.path))
    return [f"at {'/'.join(map(str, e.path)) or '(root)'}: {e.message}" for e in errors]


def check_entry(entry: Any, where: str) -> dict:
    problems = entry_problems(entry)
    if problems:
        more = f" (and {len(problems) - 1} more)" if len(problems) > 1 else ""
        raise InputError(f"{where}: not a valid leaderboard entry: {problems[0]}{more}")
    return entry


@dataclass(frozen=True)
class LeaderboardEntry:
    """One method's entry (schemas/leaderboard-entry.schema.json), checked on construction.
    `results[family][domain]` holds percent (and abs_m, median_percent, n); `results[family]["all"]`
    the All as printed or computed."""

    name: str
    method: str
    figures: str  # "published" or "computed"
    citation: str | None
    link: str | None
    results: dict[str, dict[str, Any]]
    n_obs: int | None = None
    training_data: str | None = None
    radial_input: bool | None = None
    source: str | None = None
    note: str | None = None
    scored: dict[str, Any] | None = None  # computed entries: by, date, predictions_sha256, stores
    benchmark: str = "odms"

    def __post_init__(self) -> None:
        check_entry(self.to_json(), f"entry {self.name!r}")

    def to_json(self) -> dict[str, Any]:
        d = {
            "name": self.name, "method": self.method, "n_obs": self.n_obs,
            "training_data": self.training_data, "radial_input": self.radial_input, "figures": self.figures,
            "citation": self.citation,
            "link": self.link, "source": self.source, "note": self.note, "results": self.results,
            "scored": self.scored,
        }
        if self.benchmark != "odms":
            d["benchmark"] = self.benchmark
        return {k: v for k, v in d.items() if v is not None or k not in ("source", "note", "scored")}

    @classmethod
    def from_json(cls, d: Any, where: str) -> LeaderboardEntry:
        check_entry(d, where)
        return cls(**d)


def load_entries(folder: Path | None = None, benchmark: str = "odms") -> list[LeaderboardEntry]:
    """Every entry of `folder` (default: the shipped leaderboard/) on `benchmark`, checked; names
    must be unique."""
    folder = Path(folder) if folder else resource_dir("leaderboard")
    if not folder.is_dir():
        siblings = [p.name for p in folder.parent.iterdir() if p.is_dir()] if folder.parent.is_dir() else []
        close = difflib.get_close_matches(folder.name, siblings, n=1)
        hint = f"; did you mean {folder.parent / close[0]}?" if close else ""
        raise InputError(f"{folder}: no such folder of leaderboard entries{hint}")
    if not any(folder.glob("*.json")):
        raise InputError(f"{folder}: holds no leaderboard entries (*.json files)")
    entries: list[LeaderboardEntry] = []
    seen: dict[str, Path] = {}
    for path in sorted(folder.glob("*.json")):
        entry = LeaderboardEntry.from_json(safe_json.load_file(path), str(path))
        if entry.name in seen:
            raise InputError(f"{path}: entry name {entry.name!r} is also used by {seen[entry.name]}")
        seen[entry.name] = path
        entries.append(entry)
    return [e for e in entries if e.benchmark == benchmark]


def family_all(entry: LeaderboardEntry, family: str) -> float | None:
    """The entry's All for `family`: as printed, else the mean of the four percent errors."""
    fam = entry.results.get(family, {})
    if "all" in fam:
        return fam["all"]
    return BENCHMARKS[entry.benchmark].all_of({d: v["percent"] for d, v in fam.items()})


def _cell(x: float | None, decimals: int = 1) -> str:
    return "–" if x is None else f"{x:.{decimals}f}"


def ranked(entries: list[LeaderboardEntry], family: str = "test") -> list[LeaderboardEntry]:
    """The entries with results on `family`, sorted by All (lowest first; entries without All last)."""
    if family not in SPLIT_FAMILIES:
        raise InputError(f"family must be one of {', '.join(SPLIT_FAMILIES)}, got {family!r}")

    def key(e):
        a = family_all(e, family)
        return (a is None, a if a is not None else 0.0, e.name)

    return sorted((e for e in entries if e.results.get(family)), key=key)


def render_markdown(entries: list[LeaderboardEntry], family: str = "test", metric: str = "percent",
                    benchmark: str = "odms") -> str:
    """A markdown table of the entries on `benchmark`, sorted by All (lowest first; entries
    without All last)."""
    b = BENCHMARKS[benchmark]
    domains, units = b.domains, b.units
    entries = [e for e in entries if e.benchmark == benchmark]
    if metric == "percent":
        heads = [d.replace("_", " ").capitalize() for d in domains] + ["All"]
        title = f"Mean percent error, {b.title} {family} sets (lower is better)"
    else:
        heads = [f"{d.replace('_', ' ').capitalize()} ({units[d]})" for d in domains]
        title = f"Mean absolute error, {b.title} {family} sets (lower is better; sorted by percent All)"
    lines = [
        f"{title}", "",
        "| # | Method | n | Training | " + " | ".join(heads) + " | Figures |",
        "|---|---|---|---|" + "---:|" * len(heads) + "---|",
    ]
    for rank, e in enumerate(ranked(entries, family), 1):
        fam = e.results[family]
        if metric == "percent":
            cells = [_cell(fam[d]["percent"], b.decimals) if d in fam else "–" for d in domains]
            cells.append(_cell(family_all(e, family), b.decimals))
        else:
            scale = {"m": 1.0, "cm": 100.0}
            cells = [
                _cell(fam[d]["abs_m"] * scale[units[d]], b.decimals) if "abs_m" in fam.get(d, {}) else "–"
                for d in domains
            ]
        name = markdown_link(e.name, e.link)
        n = str(e.n_obs) if e.n_obs else "–"
        train = markdown_text(e.training_data or "–")
        if e.radial_input:
            train += ", radial"
        figures = "published" if e.figures == "published" else "computed here"
        lines.append(f"| {rank} | {name} | {n} | {train} | " + " | ".join(cells) + f" | {figures} |")
    cites = sorted({e.citation for e in entries if e.citation and e.results.get(family)})
    lines += ["", "Sources: " + "; ".join(map(markdown_text, cites)) + "."]
    return "\n".join(lines) + "\n"


def entry_from_report(
    report: ScoreReport, name: str, *, method: str | None = None, citation: str | None = None,
    link: str | None = None, n_obs: int | None = None, predictions_sha256: str = "",
) -> LeaderboardEntry:
    """A computed leaderboard entry from a complete score of official splits (ODMS's, else
    ODMD's), schema-checked."""
    if report.partial:
        raise InputError("a leaderboard entry needs every example scored", fix="complete-score")
    benchmark = next((k for k, b in BENCHMARKS.items()
                      if any(b.split_of(s.split, s.domain) for s in report.scores)), "odms")
    results: dict[str, dict] = {}
    for s in report.scores:
        off = BENCHMARKS[benchmark].split_of(s.split, s.domain)
        if off is None:
            continue
        d, fam = off
        if not math.isfinite(s.mean_percent_error + s.mean_abs_error_m):
            raise InputError(f"{report.predictions}: the errors of split {s.split} are too large to be "
                             "represented (infinite); a leaderboard entry needs finite figures")
        results.setdefault(fam, {})[d] = {
            "percent": round(s.mean_percent_error, 4), "abs_m": round(s.mean_abs_error_m, 6),
            "median_percent": round(s.median_percent_error, 4), "n": s.n,
        }
    if not results:
        raise InputError(
            f"{report.predictions}: no official split (robot/driving/normal/perturb-val/test, or ODMD's "
            "odmd-normal-val ...) was scored; a leaderboard entry needs at least one"
        )
    for a in report.alls:
        if a.benchmark == benchmark:
            results[a.family]["all"] = round(a.mean_percent_error, 4)
    return LeaderboardEntry(
        name=name, method=method or name, n_obs=n_obs, training_data=None,
        radial_input=None, figures="computed", citation=citation, link=link,
        source=f"scored by odms-data {__version__} from {Path(report.predictions).name}",
        results=results,
        scored={
            "by": f"odms-data {__version__}",
            "date": datetime.date.today().isoformat(),
            "predictions_sha256": predictions_sha256 or hashlib.sha256(b"").hexdigest(),
            "stores": {s: report.digests[s] for s in sorted(report.digests)},
        },
        benchmark=benchmark,
    )
