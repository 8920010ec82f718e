"""The leaderboard: one JSON entry per method in leaderboard/ (schemas/leaderboard-entry.schema.json).

Entries are either *published* (figures as printed in the cited work) or *computed* (scored by
odms-data from a predictions file, with the store digests they were scored against). Each is on
one benchmark (BENCHMARKS): ODMS (the default), ODMS-detection (ODMD's boxes of the ODMS sets,
odms-detect-*) or ODMD, whose sets are ODMD's own four.
"""

from __future__ import annotations

import datetime
import difflib
import hashlib
import json
import math
import unicodedata
from dataclasses import dataclass
from functools import cache
from pathlib import Path
from typing import Any

from .. import safe_json
from .._version import __version__
from ..errors import InputError
from ..protocol import BENCHMARKS, SPLIT_FAMILIES, Benchmark
from ..resources import resource_dir
from ..shown_text import Markdown, markdown, markdown_join, markdown_link, one_line, web_link
from ..store.manifests import load_manifest, split_names
from .scoring import ScoreReport

ALL_KEYS = ("all", "all_ci95")  # a family's All and its interval, beside its sets


@cache
def _validator():
    import jsonschema

    schema = json.loads((resource_dir("schemas") / "leaderboard-entry.schema.json").read_text())
    return jsonschema.Draft202012Validator(schema)


def entry_problems(entry: Any) -> list[str]:
    """Every way `entry` breaks the entry schema, one line each."""
    errors = sorted(_validator().iter_errors(entry), key=lambda e: list(e.path))
    return [f"at {'/'.join(map(str, e.path)) or '(root)'}: {e.message}" for e in errors]


def name_key(name: str) -> str:
    """What makes two entry names the same: Unicode-compatible forms, white space and case aside."""
    return one_line(unicodedata.normalize("NFKC", name)).casefold()


def _all_problem(fam: dict, family: str, b: Benchmark) -> str | None:
    """Why the All of `fam` disagrees with its sets, or None: it must be their mean, to within the
    last digit the benchmark prints (the papers' All is the mean of their rounded figures)."""
    if "all" not in fam:
        return None
    if not all(d in fam for d in b.domains):
        return f"results/{family}/all: an All needs every set of {b.title} ({', '.join(b.domains)})"
    mean = sum(fam[d]["percent"] for d in b.domains) / len(b.domains)
    if abs(fam["all"] - mean) > 10.0 ** -b.decimals:
        return (f"results/{family}/all: {fam['all']} is not the mean of its sets "
                f"({mean:.{b.decimals + 2}f})")
    return None


def _interval_problem(fam: dict, family: str, computed: bool) -> str | None:
    """Why an interval of `fam` does not hold: lo <= hi always, and lo <= mean <= hi when the
    entry was computed here (both from one score)."""
    pairs = [(d, v["ci95"], v["percent"]) for d, v in fam.items() if d not in ALL_KEYS and "ci95" in v]
    if "all_ci95" in fam:
        if "all" not in fam:
            return f"results/{family}/all_ci95: an interval needs its All"
        pairs.append(("all", fam["all_ci95"], fam["all"]))
    for d, (lo, hi), mean in pairs:
        where = f"results/{family}/{d}" + ("_ci95" if d == "all" else "/ci95")
        if lo > hi:
            return f"{where}: [{lo}, {hi}] is not an interval (lo > hi)"
        if computed and not lo <= mean <= hi:
            return f"{where}: [{lo}, {hi}] does not hold its mean {mean}"
    return None


def _stores_problem(entry: dict, b: Benchmark) -> str | None:
    """Why a computed entry's store digests are not those of the split manifests of its sets."""
    if "scored" not in entry:
        return "scored: a computed entry records the stores it was scored against"
    stores = entry["scored"]["stores"]
    sets = [(d, f) for f, fam in entry["results"].items() for d in fam if d not in ALL_KEYS]
    expected = {b.split(d, f) for d, f in sets} & set(split_names())
    if set(stores) != expected:
        odd = sorted(set(stores) ^ expected)[0]
        why = "is not a split of its sets" if odd in stores else "of a scored set is missing"
        return f"scored/stores/{odd}: {why}"
    wrong = next((s for s in sorted(stores) if stores[s] != load_manifest(s).digest), None)
    return None if wrong is None else (f"scored/stores/{wrong}: {stores[wrong]} is not the digest of split "
                                       f"{wrong} (splits/{wrong}.json)")


def _problem(entry: dict) -> str | None:
    """The first way a schema-valid `entry` disagrees with itself or the split manifests."""
    b = BENCHMARKS[entry.get("benchmark", "odms")]
    if one_line(entry["name"]) != entry["name"]:
        return f"name {entry['name']!r}: white space at its ends, repeated or not a space"
    if entry["link"] is not None and web_link(entry["link"]) is None:
        return f"link {entry['link']!r}: not an http(s) address"
    for family, fam in entry["results"].items():
        other = next((d for d in fam if d not in ALL_KEYS and d not in b.domains), None)
        if other:
            return f"results/{family}/{other}: not a set of {b.title}; an entry spans one benchmark"
        if problem := _all_problem(fam, family, b) or _interval_problem(fam, family,
                                                                         entry["figures"] == "computed"):
            return problem
    return _stores_problem(entry, b) if entry["figures"] == "computed" else None


def check_entry(entry: Any, where: str) -> dict:
    """`entry` when it is a valid entry: schema-valid, its name normalised, its link an http(s)
    address, its sets one benchmark's, each All the mean of its sets, and (computed entries) its
    store digests those of the split manifests; else InputError naming the first problem."""
    problems = entry_problems(entry) or list(filter(None, [_problem(entry)]))
    if problems:
        more = f" (and {len(problems) - 1} more)" if len(problems) > 1 else ""
        raise InputError(f"{where}: not a valid leaderboard entry: {problems[0]}{more}")
    return entry


@dataclass(frozen=True)
class LeaderboardEntry:
    """One method's entry (schemas/leaderboard-entry.schema.json), checked on construction.
    `results[family][domain]` holds percent (and abs_m, median_percent, n, ci95: [lo, hi]);
    `results[family]["all"]` the All as printed or computed, `["all_ci95"]` its interval."""

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


MAX_ENTRY_BYTES = 2**20  # an entry file: a few KB of figures and names


def shipped_folder() -> Path:
    """The leaderboard/ shipped with odms-data."""
    return resource_dir("leaderboard")


def _folder_entries(folder: Path) -> list[tuple[Path, LeaderboardEntry]]:
    if not folder.is_dir():
        siblings = [p.name for p in folder.parent.iterdir() if p.is_dir()] if folder.parent.is_dir() else []
        close = difflib.get_close_matches(folder.name, siblings, n=1)
        hint = f"; did you mean {folder.parent / close[0]}?" if close else ""
        raise InputError(f"{folder}: no such folder of leaderboard entries{hint}")
    if not any(folder.glob("*.json")):
        raise InputError(f"{folder}: holds no leaderboard entries (*.json files)")
    return [(p, LeaderboardEntry.from_json(safe_json.load_file(p, max_bytes=MAX_ENTRY_BYTES), str(p)))
            for p in sorted(folder.glob("*.json"))]


def _resolved(folder: Path | str) -> Path:
    try:
        return Path(folder).resolve()
    except (OSError, RuntimeError) as e:  # a link loop
        raise InputError(f"{folder}: cannot be resolved as a folder of leaderboard entries ({e})") from None


def entry_files(*folders: Path | str) -> list[tuple[Path, LeaderboardEntry]]:
    """(file, entry) for every entry of `folders` (default: the shipped leaderboard/; a folder
    named twice is read once), checked; names must be unique across them all."""
    unique = dict.fromkeys(_resolved(f) for f in folders or [shipped_folder()])
    out: list[tuple[Path, LeaderboardEntry]] = []
    seen: dict[str, Path] = {}
    for path, entry in (pair for folder in unique for pair in _folder_entries(folder)):
        key = name_key(entry.name)
        if key in seen:
            raise InputError(f"{path}: entry name {entry.name!r} is also used by {seen[key]}")
        seen[key] = path
        out.append((path, entry))
    return out


def load_entries(*folders: Path | str, benchmark: str = "odms") -> list[LeaderboardEntry]:
    """The entries of `folders` (as `entry_files` reads them) on `benchmark`."""
    return [e for _, e in entry_files(*folders) if e.benchmark == benchmark]


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
                    benchmark: str = "odms") -> Markdown:
    """A markdown table of the entries on `benchmark`, sorted by All (lowest first; entries
    without All last); every text an entry carries escaped (shown_text.markdown)."""
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
        markdown("{title}\n", title=title),
        markdown("| # | Method | n | Training | {heads} | Figures |", heads=markdown_join(" | ", heads)),
        markdown_join("|", ["", "---", "---", "---", "---", *["---:"] * len(heads), "---", ""]),
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
        train = (e.training_data or "–") + (", radial" if e.radial_input else "")
        lines.append(markdown(
            "| {rank} | {name} | {n} | {train} | {cells} | {figures} |", rank=rank,
            name=markdown_link(e.name, e.link), n=e.n_obs or "–", train=train,
            cells=markdown_join(" | ", cells),
            figures="published" if e.figures == "published" else "computed here"))
    cites = sorted({e.citation for e in entries if e.citation and e.results.get(family)})
    if cites:
        lines.append(markdown("\nSources: {cites}.", cites=markdown_join("; ", cites)))
    lines.append(Markdown(""))
    return markdown_join("\n", lines)


def _ci95(key: str, intervals: dict[str, tuple[float, float]]) -> dict[str, list[float]]:
    """{key: [lo, hi]} of the mean percent error's interval, rounded as the mean is; {} without one."""
    ci = intervals.get("mean_percent_error")
    return {} if ci is None else {key: [round(ci[0], 4), round(ci[1], 4)]}


def entry_from_report(
    report: ScoreReport, name: str, *, method: str | None = None, citation: str | None = None,
    link: str | None = None, n_obs: int | None = None, predictions_sha256: str = "",
) -> LeaderboardEntry:
    """A computed leaderboard entry from a complete score of official splits (ODMS's, else
    ODMD's), schema-checked."""
    if report.partial:
        raise InputError("a leaderboard entry needs every example scored", fix="complete-score")
    benchmarks = {k: [s.split for s in report.scores if b.split_of(s.split, s.domain)]
                  for k, b in BENCHMARKS.items()}
    both = {k: splits for k, splits in benchmarks.items() if splits}
    if len(both) > 1:
        listed = "; ".join(f"{BENCHMARKS[k].title}: {', '.join(splits)}" for k, splits in both.items())
        raise InputError(f"{report.predictions}: scores the sets of {len(both)} benchmarks ({listed}); a "
                         "leaderboard entry spans one benchmark, so score each on its own")
    benchmark = next(iter(both), "odms")
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
            **_ci95("ci95", s.ci95),
        }
    if not results:
        raise InputError(
            f"{report.predictions}: no official split (robot/driving/normal/perturb-val/test, or ODMD's "
            "odmd-normal-val ...) was scored; a leaderboard entry needs at least one"
        )
    for a in report.alls:
        if a.benchmark == benchmark:
            results[a.family].update(all=round(a.mean_percent_error, 4), **_ci95("all_ci95", a.ci95))
    return LeaderboardEntry(
        name=one_line(name), method=method or one_line(name), n_obs=n_obs, training_data=None,
        radial_input=None, figures="computed", citation=citation, link=link,
        source=f"scored by odms-data {__version__} from {Path(report.predictions).name}",
        results=results,
        scored={
            "by": f"odms-data {__version__}",
            "date": datetime.date.today().isoformat(),
            "predictions_sha256": predictions_sha256 or hashlib.sha256(b"").hexdigest(),
            "stores": {s.split: report.digests[s.split] for s in sorted(report.scores, key=lambda s: s.split)
                       if BENCHMARKS[benchmark].split_of(s.split, s.domain)},
        },
        benchmark=benchmark,
    )
