"""Where every benchmark's figures go: one JSON file a script in benchmarks/results/, holding the
machine, date and commit of the run, the baseline measured in it, and its rows.

A script calls `add_options(parser)` and, at its end, `save(args, title, baseline, rows)`;
`python benchmarks/render_results.py` renders every file into benchmarks/RESULTS.md. A rerun
replaces the script's file (git keeps the earlier ones).
"""

from __future__ import annotations

import argparse
import datetime
import json
import math
import os
import platform
import re
import shlex
import subprocess
import sys
from pathlib import Path
from typing import Any

RESULTS = Path(__file__).resolve().parent / "results"
_STARTED = datetime.datetime.now(datetime.UTC), os.getloadavg()


def add_options(parser: argparse.ArgumentParser) -> None:
    """The options every benchmark shares: where its JSON goes and a note on how it was run."""
    parser.add_argument("--results", type=Path, default=RESULTS, help="folder of the JSON results")
    parser.add_argument("--notes", default="", help="a note on the run for the JSON (e.g. a busy machine)")


def machine() -> dict[str, Any]:
    """Cores, CPU model and memory of this machine, and its load average when the script started and now."""
    model = ""
    if Path("/proc/cpuinfo").is_file():
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                model = line.split(":", 1)[1].strip()
                break
    memory = os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES") if hasattr(os, "sysconf") else 0
    return {"cores": os.cpu_count(), "cores_usable": len(os.sched_getaffinity(0)),
            "cpu_model": model or platform.processor(), "memory_gib": round(memory / 2**30, 1),
            "system": f"{platform.system()} {platform.release()}", "python": sys.version.split()[0],
            "load_average_at_start": [round(x, 2) for x in _STARTED[1]],
            "load_average_at_end": [round(x, 2) for x in os.getloadavg()]}


def commit() -> str:
    """The commit the benchmark ran at, `+changes` when the tree differed from it."""
    root = Path(__file__).resolve().parent.parent
    try:
        head = subprocess.run(["git", "rev-parse", "--short=12", "HEAD"], cwd=root, capture_output=True,
                              text=True, check=True).stdout.strip()
        dirty = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no"], cwd=root,
                               capture_output=True, text=True, check=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return "unknown"
    return head + ("+changes" if dirty else "")


def _clean(value: Any) -> Any:
    """JSON without NaN or infinities (null instead), floats rounded to 4 significant figures."""
    if isinstance(value, float):
        return None if not math.isfinite(value) else float(f"{value:.4g}")
    if isinstance(value, dict):
        return {str(k): _clean(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_clean(v) for v in value]
    return value


ROOT = RESULTS.parent.parent
_ABSOLUTE = re.compile(r"(?<![\w.~:/])/[^\s'\"]+")  # an absolute path, up to a space or quote


def _unplaced(value: Any) -> Any:
    """`value` without this machine's paths: the clone's become relative to it, the home folder's
    start with ~, and any other absolute path is cut to .../its last part."""
    if isinstance(value, str):
        value = value.replace(f"{ROOT}/", "").replace(str(ROOT), ".").replace(f"{Path.home()}/", "~/")
        return _ABSOLUTE.sub(lambda m: ".../" + m.group(0).rstrip("/").rsplit("/", 1)[-1], value)
    if isinstance(value, dict):
        return {k: _unplaced(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_unplaced(v) for v in value]
    return value


def save(args: argparse.Namespace, title: str, baseline: dict[str, Any], rows: list[dict[str, Any]],
         extra: dict[str, Any] | None = None) -> Path:
    """Write benchmarks/results/<script>.json: `baseline` is what the rows are compared with, measured
    in the same run ({"what": ..., "value": ..., "unit": ...}); `rows` one dict a measurement, all
    with the same keys (RESULTS.md's table); `extra` anything else worth keeping. No path of this
    machine is written (`_unplaced`)."""
    script = Path(sys.argv[0]).name
    record = {"script": f"benchmarks/{script}", "title": title,
              "command": shlex.join(["python", f"benchmarks/{script}", *sys.argv[1:]]),
              "date": _STARTED[0].strftime("%Y-%m-%d %H:%M UTC"), "commit": commit(), "machine": machine(),
              "notes": args.notes, "baseline": baseline, "rows": rows, **(extra or {})}
    record = _unplaced(record)
    args.results.mkdir(parents=True, exist_ok=True)
    path = args.results / f"{Path(script).stem}.json"
    partial = path.with_name(path.name + ".partial")
    partial.write_text(json.dumps(_clean(record), indent=1, allow_nan=False) + "\n")
    partial.replace(path)
    print(f"wrote {path}")
    return path
