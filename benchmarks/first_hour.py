"""Your first hour: the README's block, run as written from the project root, each step timed.

    python benchmarks/first_hour.py [--small] [--skip-install]

The block is the README's ```bash fence after the `<!-- first-hour` marker, run by bash with
`set -euo pipefail`, one step a command (a line, with its continuation lines). `--small` sets
ITERATIONS=4 STEPS=3, as `.ci/run` does; `--skip-install` leaves out the block's `pip install`
line (for an environment that has the extras, such as the development install). Afterwards the
scores of the block's predictions files are read with `score --json` (each in the row of the step
that wrote it: mean percent error on sim-val), and the run fails when the
block left anything in `git status` or a step failed. The baseline is the main job alone,
`odms-data generate --split sim-val` in a fresh folder, timed in the same run.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import _results  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
MARKER = "<!-- first-hour"


def block(readme: Path) -> list[str]:
    """The block's commands, each with its continuation lines joined."""
    text = readme.read_text()
    start = text.index(MARKER)
    fence = text.index("```bash\n", start) + len("```bash\n")
    lines = text[fence : text.index("\n```", fence)].splitlines()
    steps, current = [], ""
    for line in lines:
        current += line + "\n"
        if not line.rstrip().endswith("\\"):
            steps.append(current.rstrip("\n"))
            current = ""
    return [s for s in steps if s.strip() and not s.lstrip().startswith("#")]


def git_status() -> set[str]:
    """The paths git status names: new, changed or deleted, untracked files one by one."""
    out = subprocess.run(["git", "status", "--porcelain", "--untracked-files=all"], cwd=ROOT,
                         capture_output=True, text=True, check=True).stdout
    return set(out.splitlines())


def run_block(steps: list[str], env: dict[str, str], log: Path) -> tuple[list[float], Path]:
    """Run the steps in one bash process, from the project root: each step's seconds, the folder
    the block ended in."""
    marks, where = log.with_suffix(".marks"), log.with_suffix(".where")
    script = ["set -euo pipefail", f'__mark() {{ date +%s.%N >> "{marks}"; }}', "__mark"]
    for step in steps:
        script += [step, "__mark"]
    script.append(f'pwd > "{where}"')
    with open(log, "w") as out:
        r = subprocess.run(["bash", "-c", "\n".join(script)], cwd=ROOT, env=env, stdout=out,
                           stderr=subprocess.STDOUT)
    times = [float(t) for t in marks.read_text().split()]
    if r.returncode:
        failed = steps[len(times) - 1]
        tail = "".join(log.read_text().splitlines(keepends=True)[-15:])
        raise SystemExit(f"the first hour failed at `{failed}` (exit code {r.returncode}):\n{tail}")
    return [b - a for a, b in zip(times, times[1:], strict=False)], Path(where.read_text().strip())


def scores(folder: Path, env: dict[str, str]) -> dict[str, float | None]:
    """Mean percent error on sim-val of each predictions file the block wrote."""
    out: dict[str, float | None] = {}
    for csv in sorted(folder.glob("*.csv")):
        r = subprocess.run([sys.executable, "-m", "odms_data.cli", "score", str(csv), "--data",
                            str(folder / "sim-val.zarr"), "--json"], capture_output=True, text=True, env=env)
        if r.returncode == 0:
            split = next(x for x in json.loads(r.stdout)["splits"] if x["split"] == "sim-val")
            out[csv.name] = split["mean_percent_error"]
    return out


def written(step: str) -> str | None:
    """The predictions file a step writes (`-o x.csv`, `--out x.csv`), if any."""
    m = re.search(r"(?:-o|--out)\s+(\S+\.csv)\b", step)
    return m.group(1) if m else None


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--small", action="store_true", help="ITERATIONS=4 STEPS=3, no JSON (what .ci/run runs)")
    ap.add_argument("--skip-install", action="store_true", help="leave out the block's pip install line")
    _results.add_options(ap)
    a = ap.parse_args()
    steps = block(ROOT / "README.md")
    if a.skip_install:
        steps = [s for s in steps if not s.startswith("pip install")]
    env = {**os.environ, **({"ITERATIONS": "4", "STEPS": "3"} if a.small else {})}
    before = git_status()
    with tempfile.TemporaryDirectory() as tmp:
        t = time.perf_counter()
        subprocess.run([sys.executable, "-m", "odms_data.cli", "generate", "--split", "sim-val"], cwd=tmp,
                       env=env, check=True, capture_output=True)
        main_job = time.perf_counter() - t
        t = time.perf_counter()
        seconds, scratch = run_block(steps, env, Path(tmp) / "first-hour.log")
        total = time.perf_counter() - t
    try:
        found = scores(scratch, env)
    finally:
        if scratch != ROOT and Path(tempfile.gettempdir()) in scratch.parents:
            shutil.rmtree(scratch)
    left = git_status() - before
    if left:
        raise SystemExit("the first hour left files in the clone:\n" + "\n".join(sorted(left)))
    for step, secs in zip(steps, seconds, strict=True):
        print(f"{secs:7.1f} s  {step.splitlines()[0][:100]}")
    print(f"{total:7.1f} s  in all; scores on sim-val (mean percent error): {found}")
    rows = [{"step": re.sub(r"\s+#.*", "", s).replace("\\\n", "").replace("  ", " ").strip(), "seconds": secs,
             "mean % error on sim-val": found.get(written(s) or "")}
            for s, secs in zip(steps, seconds, strict=True)]
    if a.small:
        a.notes = "; ".join(x for x in (a.notes, "ITERATIONS=4 STEPS=3, as .ci/run runs it") if x)
    _results.save(a, "Your first hour: the README's block, step by step",
                  {"what": "the main job alone, `odms-data generate --split sim-val`", "value": main_job,
                   "unit": "s"}, rows,
                  {"total_seconds": total, "mean_percent_error_on_sim_val": found,
                   "skipped_install": a.skip_install})


if __name__ == "__main__":
    main()
