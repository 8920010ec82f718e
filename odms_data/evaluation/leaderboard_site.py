"""The leaderboard as a static site (`odms-data leaderboard --html DIR`): one page per benchmark,
one per entry, self-contained (no external script, font or style; inline CSS and a small inline
script that sorts the columns), so it works from file:// and from any static host.

Every page is rendered by shown_text.html (Jinja2, every value escaped, links http(s) only), and
carries a Content-Security-Policy that lets only its own inline script and style run: were a
value ever to slip through unescaped, a script it carried would not run.

A set's cell shows the entry's mean percent error and, where the entry records it (`score
--entry` does), its 95 % cluster-bootstrap interval. Ties are neighbours that `compare` cannot
separate on All, where both ship their predictions and the stores are given (TieJudge); else
neighbours whose All is equal at the precision the benchmark prints. A footnote says which rule made each tie.
"""

from __future__ import annotations

import base64
import hashlib
import re
from collections.abc import Sequence
from pathlib import Path

from .._version import __version__
from ..errors import InputError
from ..outputs import OutputType, atomic_folder
from ..protocol import BENCHMARKS, SPLIT_FAMILIES
from ..shown_text import html
from .compare import all_name, compare
from .error_plots import plot_errors
from .evaluate import Evaluation
from .leaderboard import LeaderboardEntry, family_all, name_key, ranked
from .scoring import ScoreReport

GENERATOR = f"odms-data {__version__}"

STYLE = """
body { font: 15px/1.45 system-ui, sans-serif; margin: 1.5em auto; max-width: 72em; padding: 0 1em; }
nav a { margin-right: 1em; }
table { border-collapse: collapse; margin: 0.5em 0 1.5em; }
th, td { border-bottom: 1px solid #ddd; padding: 0.25em 0.6em; text-align: left; vertical-align: top; }
table.board td, table.board th { white-space: nowrap; }
td.num { text-align: right; font-variant-numeric: tabular-nums; }
th button { font: inherit; font-weight: bold; border: 0; background: none; cursor: pointer; padding: 0; }
th[aria-sort=ascending] button::after { content: " \\25B2"; }
th[aria-sort=descending] button::after { content: " \\25BC"; }
.computed { color: #05603a; font-weight: bold; }
.tie { color: #b54708; }
code { font-size: 12px; }
details summary { cursor: pointer; }
"""

SCRIPT = """
document.querySelectorAll("table.board").forEach(function (table) {
  var heads = table.tHead.rows[0].cells;
  Array.prototype.forEach.call(heads, function (th, col) {
    var button = th.querySelector("button");
    if (!button) { return; }
    button.addEventListener("click", function () {
      var ascending = th.getAttribute("aria-sort") !== "ascending";
      Array.prototype.forEach.call(heads, function (h) { h.removeAttribute("aria-sort"); });
      th.setAttribute("aria-sort", ascending ? "ascending" : "descending");
      var body = table.tBodies[0];
      var rows = Array.prototype.slice.call(body.rows);
      rows.sort(function (a, b) {
        var x = a.cells[col].getAttribute("data-sort"), y = b.cells[col].getAttribute("data-sort");
        if (x === "" || y === "") { return (x === "") - (y === ""); }  // no figure: last either way
        var nx = parseFloat(x), ny = parseFloat(y);
        var order = isNaN(nx) || isNaN(ny) ? x.localeCompare(y) : nx - ny;
        return ascending ? order : -order;
      });
      rows.forEach(function (r) { body.appendChild(r); });
    });
  });
});
"""


def _hash(text: str) -> str:
    return "sha256-" + base64.b64encode(hashlib.sha256(text.encode()).digest()).decode()


POLICY = (f"default-src 'none'; style-src '{_hash(STYLE)}'; script-src '{_hash(SCRIPT)}'; "
          "img-src 'self' data:; base-uri 'none'; form-action 'none'")

HEAD = """<!DOCTYPE html>
<html lang="en">
<head>
<meta charset="utf-8">
<meta http-equiv="Content-Security-Policy" content="{{ policy }}">
<meta name="generator" content="{{ generator }}">
<meta name="viewport" content="width=device-width, initial-scale=1">
<title>{{ title }}</title>
<style>{{ style|safe }}</style>
</head>
<body>
<nav>{% for key, b in benchmarks %}<a href="{{ up }}{{ key }}.html">{{ b.title }}</a>{% endfor %}</nav>
"""

BENCHMARK_PAGE = HEAD + """<h1>{{ title }}</h1>
<p>Mean percent error, lower is better; All is the unweighted mean of the sets. Click a column
heading to sort. <span class="computed">computed here</span>: scored by odms-data from a
predictions file against the stores whose digests are listed; published: as printed in the cited
work. [lo, hi] after a mean: its 95 % cluster-bootstrap interval, where the entry records one.
<span class="tie">=</span> marks a tie; its footnote says by which rule.</p>
{% for family, rows, notes in tables %}
<h2>{{ family }} sets</h2>
{% if rows %}
<table class="board" id="board-{{ family }}">
<thead><tr>{% for head in heads %}<th><button type="button">{{ head }}</button></th>{% endfor %}</tr></thead>
<tbody>
{% for r in rows %}
<tr>
<td class="num" data-sort="{{ r.rank }}">
{%- if r.ties %}<span class="tie" title="tied">=</span>
{%- for rule in r.ties|sort %}
<sup><a href="#tie-{{ rule }}-{{ family }}">{{ marks[rule] }}</a></sup>{% endfor %}
{%- endif %}{{ r.rank }}</td>
<td data-sort="{{ r.name }}"><a href="entries/{{ r.page }}">{{ r.name }}</a></td>
<td class="num" data-sort="{{ r.n or "" }}">{{ r.n or "–" }}</td>
<td data-sort="{{ r.training }}">{{ r.training }}</td>
{% for c in r.cells %}<td class="num" data-sort="{{ c.sort }}">{{ c.text }}</td>{% endfor %}
<td data-sort="{{ r.figures }}">
{%- if r.computed %}<span class="computed">computed here</span>{% else %}published{% endif %}</td>
<td data-sort="{{ r.stores|length }}">{% if r.stores %}
<details><summary>{{ r.stores|length }} stores</summary>
{% for split, digest in r.stores %}<div><code>{{ split }} {{ digest }}</code></div>{% endfor %}
</details>{% else %}–{% endif %}</td>
</tr>
{% endfor %}
</tbody>
</table>
{% for rule, mark, text in notes %}
<p id="tie-{{ rule }}-{{ family }}"><sup>{{ mark }}</sup> {{ text }}</p>
{% endfor %}
{% else %}
<p>No entry has figures on these sets yet.</p>
{% endif %}
{% endfor %}
{% if cites %}<p>Sources: {{ cites|join("; ") }}.</p>{% endif %}
<script>{{ script|safe }}</script>
</body>
</html>
"""

ENTRY_PAGE = HEAD + """<h1>{{ e.name }}</h1>
<p>{{ b.title }} entry; figures
{%- if e.figures == "computed" %} <span class="computed">computed here</span>
{%- else %} published{% endif %}.</p>
<table>
<tr><th>Method</th><td>{{ e.method }}</td></tr>
<tr><th>Citation</th><td>{{ e.citation or "–" }}</td></tr>
<tr><th>Link</th><td>{% if e.link|link %}
<a href="{{ e.link|link }}" rel="noopener noreferrer">{{ e.link|link }}</a>{% else %}–{% endif %}</td></tr>
<tr><th>Observations</th><td>{{ e.n_obs or "–" }}</td></tr>
<tr><th>Training data</th>
<td>{{ e.training_data or "–" }}{% if e.radial_input %}, radial input{% endif %}</td></tr>
{% if e.source %}<tr><th>Source</th><td>{{ e.source }}</td></tr>{% endif %}
{% if e.note %}<tr><th>Note</th><td>{{ e.note }}</td></tr>{% endif %}
{% if e.scored %}<tr><th>Scored</th><td>by {{ e.scored.by }} on {{ e.scored.date }}; predictions sha256
<code>{{ e.scored.predictions_sha256 }}</code></td></tr>{% endif %}
</table>
{% for family, sets in results %}
<h2>{{ family }} sets</h2>
<table>
<thead><tr><th>Set</th><th>Mean %</th><th>95 % interval</th><th>Median %</th>
<th>Mean abs. error (m)</th><th>n</th><th>Store digest</th></tr></thead>
<tbody>
{% for s in sets %}
<tr><td>{{ s.set }}</td>
{% for x in (s.percent, s.ci, s.median, s.abs, s.n) %}<td class="num">{{ x }}</td>{% endfor %}
<td><code>{{ s.digest }}</code></td></tr>
{% endfor %}
</tbody>
</table>
{% endfor %}
{% if plot %}
<h2>Breakdowns</h2>
<p>Percent error against true depth, then the mean percent error by depth bin and by camera travel,
one panel per set, from the predictions this entry ships, scored on the stores given.</p>
<img src="{{ plot }}" alt="{{ e.name }}: error by depth and by motion" style="max-width: 100%">
{% endif %}
<script>{{ script|safe }}</script>
</body>
</html>
"""


def _not_a_site(path: Path) -> str | None:
    """What makes `path` something else than an earlier site or an empty folder (None if not)."""
    if not path.is_dir():
        return "is a file, not an earlier leaderboard site"
    if not any(path.iterdir()):
        return None
    index = path / "index.html"
    if index.is_file() and not index.is_symlink():
        with open(index, "rb") as f:
            if b'<meta name="generator" content="odms-data' in f.read(2048):
                return None
    return "is a folder odms-data did not write as a leaderboard site"


SITE = OutputType("leaderboard site", _not_a_site)


def entry_page(entry: LeaderboardEntry) -> str:
    """The file name of an entry's page: its name made safe for a path, and a hash of it."""
    key = name_key(entry.name)
    slug = re.sub(r"[^a-z0-9]+", "-", key).strip("-")[:40] or "entry"
    return f"{slug}-{hashlib.sha256(key.encode()).hexdigest()[:8]}.html"


def _number(x: float | None, decimals: int, ci95: list[float] | None = None) -> dict[str, str]:
    """A cell sorted by `x`, showing `x [lo, hi]` where it has an interval, else `x` alone."""
    text = "–" if x is None else f"{x:.{decimals}f}"
    if x is not None and ci95 is not None:
        text += f" [{ci95[0]:.{decimals}f}, {ci95[1]:.{decimals}f}]"
    return {"sort": "" if x is None else repr(x), "text": text}


def _set_cell(figures: dict | None, decimals: int) -> dict[str, str]:
    """A set's cell: its mean percent error, with its 95 % interval where the entry has one."""
    return _number(None if figures is None else figures["percent"], decimals,
                   None if figures is None else figures.get("ci95"))


TIE_RULES = {  # rule: (footnote mark, what it says)
    "compare": ("c", "Tied by `odms-data compare`: both ship their predictions, and the paired comparison "
                     "of their All on the given stores cannot separate them (p >= 0.05 or a 95 % interval "
                     "of the difference that includes 0)."),
    "precision": ("p", "Tied at the printed precision: the same All to the digits shown (no paired "
                       "comparison: an entry ships no predictions, or no stores were given)."),
}


class TieJudge:
    """Whether `compare` can separate two entries' All, where both ship predictions (entry name ->
    CSV) and `data` holds the stores; each file is scored once."""

    def __init__(self, predictions: dict[str, Path], data: Sequence[str]):
        self.predictions, self.data = predictions, data
        self.reports: dict[str, ScoreReport] = {}

    def can_score(self, e: LeaderboardEntry) -> bool:
        return bool(self.data) and e.name in self.predictions

    def report(self, name: str) -> ScoreReport:
        if name not in self.reports:
            _, self.reports[name] = Evaluation(self.data).score(self.predictions[name], intervals=False)
        return self.reports[name]

    def tied(self, a: LeaderboardEntry, b: LeaderboardEntry, family: str) -> bool | None:
        """True when compare cannot separate them on All, False when it can; None when it cannot
        run (no data, no predictions, or files that do not cover the same examples)."""
        if not (self.can_score(a) and self.can_score(b)):
            return None
        try:
            c = compare(self.report(a.name), self.report(b.name))
        except InputError:
            return None
        bench = BENCHMARKS[a.benchmark]
        name = all_name(a.benchmark, bench.title, family)
        found = next((d for d in c.alls if d.name == name), None)
        return None if found is None else found.better is None


def _tie(judge: TieJudge, prev: dict | None, e: LeaderboardEntry, shown: float | None,
         family: str) -> str | None:
    """The rule by which `e` ties with the row above it, or None."""
    if prev is None:
        return None
    by_compare = judge.tied(prev["entry"], e, family)
    if by_compare is not None:
        return "compare" if by_compare else None
    return "precision" if shown is not None and prev["all"] == shown else None


def _rows(entries: list[LeaderboardEntry], family: str, benchmark: str, judge: TieJudge) -> list[dict]:
    b = BENCHMARKS[benchmark]
    rows: list[dict] = []
    for e in ranked(entries, family):
        fam, total = e.results[family], family_all(e, family)
        shown = None if total is None else round(total, b.decimals)
        rule = _tie(judge, rows[-1] if rows else None, e, shown, family)
        rank = rows[-1]["rank"] if rule else len(rows) + 1
        if rule:
            rows[-1]["ties"].add(rule)
        rows.append({
            "entry": e, "rank": rank, "ties": {rule} if rule else set(), "all": shown, "name": e.name,
            "page": entry_page(e), "n": e.n_obs,
            "training": (e.training_data or "–") + (", radial" if e.radial_input else ""),
            "cells": [_set_cell(fam.get(d), b.decimals) for d in b.domains]
            + [_number(total, b.decimals, fam.get("all_ci95"))],
            "figures": e.figures, "computed": e.figures == "computed",
            "stores": sorted((e.scored or {}).get("stores", {}).items()),
        })
    return rows


def _interval(ci95: list[float] | None) -> str:
    return "–" if ci95 is None else f"[{ci95[0]}, {ci95[1]}]"


def _entry_sets(entry: LeaderboardEntry) -> list[tuple[str, list[dict]]]:
    b = BENCHMARKS[entry.benchmark]
    stores = (entry.scored or {}).get("stores", {})
    digest = {(d, f): stores[b.split(d, f)] for f in SPLIT_FAMILIES for d in b.domains
              if b.split(d, f) in stores}
    out = []
    for family in SPLIT_FAMILIES:
        fam = entry.results.get(family)
        if not fam:
            continue
        sets = [{"set": d.replace("_", " "), "percent": fam[d]["percent"],
                 "ci": _interval(fam[d].get("ci95")), "median": fam[d].get("median_percent", "–"),
                 "abs": fam[d].get("abs_m", "–"),
                 "n": fam[d].get("n", "–"), "digest": digest.get((d, family), "–")}
                for d in b.domains if d in fam]
        if "all" in fam:
            none = dict.fromkeys(("median", "abs", "n", "digest"), "–")
            sets.append({"set": "All", "percent": fam["all"], "ci": _interval(fam.get("all_ci95")), **none})
        out.append((family, sets))
    return out


def _table(entries: list[LeaderboardEntry], family: str, benchmark: str, judge: TieJudge) -> tuple:
    """(family, rows, footnotes of the tie rules its rows use)."""
    rows = _rows(entries, family, benchmark, judge)
    used = set().union(*(r["ties"] for r in rows))
    return family, rows, [(rule, mark, text) for rule, (mark, text) in TIE_RULES.items() if rule in used]


def write_site(entries: list[LeaderboardEntry], out_dir: str | Path, *, overwrite: bool = False,
               predictions: dict[str, Path] | None = None, data: Sequence[str] = ()) -> list[str]:
    """Write the site for `entries` (of every benchmark) to `out_dir`; returns its pages, relative.
    With `data` (stores) and `predictions` (entry name -> the CSV it ships), neighbours that both
    ship predictions tie when `compare` cannot separate them, and their entry pages show their
    breakdown plots (a PNG beside the page)."""
    judge = TieJudge(predictions or {}, data)
    common = {"policy": POLICY, "generator": GENERATOR, "style": STYLE, "script": SCRIPT,
              "benchmarks": list(BENCHMARKS.items()), "marks": {k: v[0] for k, v in TIE_RULES.items()}}
    pages: dict[str, str] = {}
    plots: dict[str, LeaderboardEntry] = {}  # entries/NAME.png: the entry whose breakdowns it draws
    for key, b in BENCHMARKS.items():
        mine = [e for e in entries if e.benchmark == key]
        sets = [d.replace("_", " ").capitalize() for d in b.domains]
        heads = ["#", "Method", "n", "Training", *sets, "All", "Figures", "Stores"]
        tables = [_table(mine, f, key, judge) for f in reversed(SPLIT_FAMILIES)]  # test first
        cites = sorted({e.citation for e in mine if e.citation})
        pages[f"{key}.html"] = html(BENCHMARK_PAGE, **common, up="", title=f"{b.title} leaderboard",
                                    heads=heads, tables=tables, cites=cites)
        for e in mine:
            plot = entry_page(e).removesuffix(".html") + ".png" if judge.can_score(e) else None
            if plot:
                plots[f"entries/{plot}"] = e
            pages[f"entries/{entry_page(e)}"] = html(ENTRY_PAGE, **common, up="../", title=e.name, e=e, b=b,
                                                     results=_entry_sets(e), plot=plot)
    pages["index.html"] = pages[f"{next(iter(BENCHMARKS))}.html"]
    with atomic_folder(out_dir, SITE, overwrite=overwrite) as partial:
        (partial / "entries").mkdir()
        for name, text in pages.items():
            (partial / name).write_text(text, encoding="utf-8")
        for name, e in plots.items():
            plot_errors(judge.report(e.name), str(partial / name))
    return sorted(pages)
