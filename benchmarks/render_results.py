"""Render every benchmark's JSON in benchmarks/results/ into benchmarks/RESULTS.md.

    python benchmarks/render_results.py [--check]

One section a script: what it measures, the command, when, where (cores, CPU model, load), the
commit, the baseline measured in the same run and the table of its rows. `--check` exits 1 when
RESULTS.md differs from what the JSON files render to.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

HERE = Path(__file__).resolve().parent
HEADER = """# Benchmark results

Every figure the README and the docs quote comes from here. Each section is one script's latest
run, rendered from its JSON in [results/](results/) by `python benchmarks/render_results.py`;
rerun the script on your machine to get your own (it rewrites its JSON). Every script measures
its baseline in the same run, so compare ratios across machines, not rates. A retired script's
section keeps its last run and says where git keeps the script; `asv continuous` in asv_bench/
compares any two commits instead (docs/DEVELOPING.md, Benchmarks).
"""


def cell(value: Any) -> str:
    if value is None:
        return "–"
    if isinstance(value, float):
        return f"{value:,.3g}" if abs(value) < 100 else f"{value:,.0f}"
    if isinstance(value, int) and not isinstance(value, bool):
        return f"{value:,}"
    return str(value).replace("|", "\\|")


def load(m: dict[str, Any]) -> str:
    start, end = m.get("load_average_at_start"), m.get("load_average_at_end")
    if not (start and end):  # a run recorded before the scripts wrote JSON
        return "load average not recorded"
    return f"load average {start[0]} at the start, {end[0]} at the end"


def command(r: dict[str, Any]) -> str:
    """The command that made `r`, or, for a script gone from benchmarks/, where git keeps it."""
    if (HERE.parent / r["script"]).is_file():
        return f"`{r['command']}`"
    commit, changed = r["commit"].partition("+")[::2]
    if changed:  # it ran beside uncommitted changes: the script may be in a later commit
        return f"Retired script, in git: `git log -- {r['script']}` (it ran at {commit} with changes)"
    return f"Retired script, in git: `git show {commit}:{r['script']}`"


def section(r: dict[str, Any]) -> str:
    m = r["machine"]
    lines = [f"## {r['title']}", "", command(r), "",
             f"- run {r['date']} at commit {r['commit']}",
             f"- machine: {m['cores']} cores ({m['cores_usable']} usable), {m['cpu_model']}, "
             f"{m['memory_gib']} GiB, {m['system']}, Python {m['python']}; " + load(m)]
    if r.get("notes"):
        lines.append(f"- notes: {r['notes']}")
    b = r["baseline"]
    if b:
        value = f"{cell(b['value'])} {b.get('unit', '')}"
        lines.append(f"- baseline, measured in the same run: {b['what']}: {value}")
    rows = r["rows"]
    if rows:
        keys = list(rows[0])
        lines += ["", "| " + " | ".join(keys) + " |", "|" + "|".join("---" for _ in keys) + "|"]
        lines += ["| " + " | ".join(cell(row.get(k)) for k in keys) + " |" for row in rows]
    return "\n".join(lines) + "\n"


def render(folder: Path) -> str:
    records = [json.loads(p.read_text()) for p in sorted(folder.glob("*.json"))]
    return HEADER + "".join("\n" + section(r) for r in records)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--check", action="store_true", help="only check that RESULTS.md is current")
    a = ap.parse_args()
    text, target = render(HERE / "results"), HERE / "RESULTS.md"
    if a.check:
        if not target.is_file() or target.read_text() != text:
            sys.exit("benchmarks/RESULTS.md is stale: run python benchmarks/render_results.py")
        return
    target.write_text(text)
    print(f"wrote {target}")


if __name__ == "__main__":
    main()
