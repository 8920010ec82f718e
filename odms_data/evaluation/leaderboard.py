"""The leaderboard: one JSON entry per method in leaderboard/ (schemas/leaderboard-entry.schema.json).

Entries are either *published* (figures as printed in the cited work) or *computed* (scored by
odms-data from a predictions file, with the store digests they were scored against).
"""

from __future__ import annotations

import datetime
import hashlib
import json
import math
from functools import cache
from pathlib import Path
from typing import Any

from .. import safe_json
from .._version import __version__
from ..benchmark import ABS_UNITS, FAMILIES, OFFICIAL_DOMAINS, official_name
from ..errors import InputError
from ..resources import resource_dir
from .scoring import ScoreReport


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


def load_entries(folder: Path | None = None) -> list[dict]:
    """Every entry of `folder` (default: the shipped leaderboard/), checked; names must be unique."""
    folder = Path(folder) if folder else resource_dir("leaderboard")
    entries: list[dict] = []
    seen: dict[str, Path] = {}
    for path in sorted(folder.glob("*.json")):
        entry = safe_json.load_file(path)
        check_entry(entry, str(path))
        if entry["name"] in seen:
            raise InputError(f"{path}: entry name {entry['name']!r} is also used by {seen[entry['name']]}")
        seen[entry["name"]] = path
        entries.append(entry)
    return entries


def family_all(entry: dict, family: str) -> float | None:
    """The entry's All for `family`: as printed, else the mean of the four percent errors."""
    fam = entry["results"].get(family, {})
    if "all" in fam:
        return fam["all"]
    if all(d in fam for d in OFFICIAL_DOMAINS):
        return sum(fam[d]["percent"] for d in OFFICIAL_DOMAINS) / len(OFFICIAL_DOMAINS)
    return None


def _cell(x: float | None) -> str:
    return "–" if x is None else f"{x:.1f}"


def ranked(entries: list[dict], family: str = "test") -> list[dict]:
    """The entries with results on `family`, sorted by All (lowest first; entries without All last)."""
    if family not in FAMILIES:
        raise InputError(f"family must be one of {', '.join(FAMILIES)}, got {family!r}")

    def key(e):
        a = family_all(e, family)
        return (a is None, a if a is not None else 0.0, e["name"])

    return sorted((e for e in entries if e["results"].get(family)), key=key)


def render_markdown(entries: list[dict], family: str = "test", metric: str = "percent") -> str:
    """A markdown table sorted by All (lowest first; entries without All last)."""

    if metric == "percent":
        heads = [d.capitalize() for d in OFFICIAL_DOMAINS] + ["All"]
        title = f"Mean percent error, ODMS {family} sets (lower is better)"
    else:
        heads = [f"{d.capitalize()} ({ABS_UNITS[d]})" for d in OFFICIAL_DOMAINS]
        title = f"Mean absolute error, ODMS {family} sets (lower is better; sorted by percent All)"
    lines = [
        f"{title}", "",
        "| # | Method | n | Training | " + " | ".join(heads) + " | Figures |",
        "|---|---|---|---|" + "---:|" * len(heads) + "---|",
    ]
    for rank, e in enumerate(ranked(entries, family), 1):
        fam = e["results"][family]
        if metric == "percent":
            cells = [_cell(fam[d]["percent"]) if d in fam else "–" for d in OFFICIAL_DOMAINS]
            cells.append(_cell(family_all(e, family)))
        else:
            scale = {"m": 1.0, "cm": 100.0}
            cells = [
                _cell(fam[d]["abs_m"] * scale[ABS_UNITS[d]]) if "abs_m" in fam.get(d, {}) else "–"
                for d in OFFICIAL_DOMAINS
            ]
        name = f"[{e['name']}]({e['link']})" if e.get("link") else e["name"]
        n = str(e["n_obs"]) if e.get("n_obs") else "–"
        train = e.get("training_data") or "–"
        if e.get("radial_input"):
            train += ", radial"
        figures = "published" if e["figures"] == "published" else "computed here"
        lines.append(f"| {rank} | {name} | {n} | {train} | " + " | ".join(cells) + f" | {figures} |")
    cites = sorted({e["citation"] for e in entries if e.get("citation") and e["results"].get(family)})
    lines += ["", "Sources: " + "; ".join(cites) + "."]
    return "\n".join(lines) + "\n"


def entry_from_report(
    report: ScoreReport, name: str, *, method: str | None = None, citation: str | None = None,
    link: str | None = None, n_obs: int | None = None, predictions_sha256: str = "",
) -> dict:
    """A computed leaderboard entry from a complete score of official splits, schema-checked."""
    if report.partial:
        raise InputError("a leaderboard entry needs every example scored; drop --allow-partial")
    results: dict[str, dict] = {}
    for s in report.scores:
        off = official_name(s.split, s.domain)
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
    for fam, value in report.all.items():
        results[fam]["all"] = round(value, 4)
    if not results:
        raise InputError(
            f"{report.predictions}: no official split (robot/driving/normal/perturb-val/test) was scored; "
            "a leaderboard entry needs at least one"
        )
    entry = {
        "name": name, "method": method or name, "n_obs": n_obs, "training_data": None,
        "radial_input": None, "figures": "computed", "citation": citation, "link": link,
        "source": f"scored by odms-data {__version__} from {Path(report.predictions).name}",
        "results": results,
        "scored": {
            "by": f"odms-data {__version__}",
            "date": datetime.date.today().isoformat(),
            "predictions_sha256": predictions_sha256 or hashlib.sha256(b"").hexdigest(),
            "stores": {s: report.digests[s] for s in sorted(report.digests)},
        },
    }
    return check_entry(entry, f"entry {name!r}")
