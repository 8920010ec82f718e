"""Start-up cost of the command line and the package: this tree against an earlier commit.

Run by hand: `python benchmarks/startup.py [--base REV] [--repeat 15]`. The earlier commit
(default: the last one before the layered package) is checked out into a temporary git worktree,
and both trees are timed in the same run, alternating, each as a fresh interpreter with the
tree first on PYTHONPATH (and the working directory outside both trees):

- `odms-data --help` (`python -m odms_data.cli --help`);
- `python -c "import odms_data"`;
- `python -c "import odms_data.store.masks"` here, `import odms_data.masks` there (one small
  module: what a worker that has not loaded it pays to unpickle a task that names it).

Medians of --repeat runs, wall time, with the number of odms_data modules each import loads.
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import _results  # noqa: E402

REPO = Path(__file__).resolve().parents[1]
BEFORE_LAYOUT = "8e76e8e"  # main before issue 11's layered package


def wall(tree: Path, args: list[str]) -> float:
    env = {**os.environ, "PYTHONPATH": str(tree)}
    start = time.perf_counter()
    subprocess.run([sys.executable, *args], env=env, check=True, stdout=subprocess.DEVNULL, cwd=tree.parent)
    return time.perf_counter() - start


def modules(tree: Path, module: str) -> int:
    code = f"import sys, {module}; print(sum(m.startswith('odms_data') for m in sys.modules))"
    out = subprocess.run([sys.executable, "-c", code], env={**os.environ, "PYTHONPATH": str(tree)},
                         check=True, capture_output=True, text=True, cwd=tree.parent).stdout
    return int(out)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--base", default=BEFORE_LAYOUT, help="earlier commit to compare with")
    parser.add_argument("--repeat", type=int, default=15)
    _results.add_options(parser)
    args = parser.parse_args()
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        base = Path(tmp) / "base"
        git = ["git", "-C", str(REPO), "worktree"]
        subprocess.run([*git, "add", "-q", "--detach", str(base), args.base], check=True)
        try:
            cases = {
                "odms-data --help": (["-m", "odms_data.cli", "--help"],) * 2,
                "import odms_data": (["-c", "import odms_data"],) * 2,
                "import one small module": (["-c", "import odms_data.masks"],
                                            ["-c", "import odms_data.store.masks"]),
            }
            print(f"{'':26} {args.base:>10} {'this tree':>10}  ratio   (median of {args.repeat}, s)")
            for name, (old, new) in cases.items():
                times: dict[str, list[float]] = {"base": [], "here": []}
                for _ in range(args.repeat):
                    times["base"].append(wall(base, old))
                    times["here"].append(wall(REPO, new))
                b, h = statistics.median(times["base"]), statistics.median(times["here"])
                print(f"{name:26} {b:10.3f} {h:10.3f}  {b / h:5.1f}x")
                rows.append({"command": name, f"{args.base} (s)": b, "this tree (s)": h, "ratio": b / h})
            small = (modules(base, "odms_data.masks"), modules(REPO, "odms_data.store.masks"))
            loaded = {"import odms_data": (modules(base, "odms_data"), modules(REPO, "odms_data")),
                      "one small module": small}
            print(f"odms_data modules loaded by 'import odms_data': {loaded['import odms_data'][0]} before, "
                  f"{loaded['import odms_data'][1]} now; by one small module: "
                  f"{loaded['one small module'][0]} before, {loaded['one small module'][1]} now")
        finally:
            subprocess.run([*git, "remove", "--force", str(base)], check=True)
    _results.save(args, f"Start-up of the command line and the package (median of {args.repeat}, wall)",
                  {"what": f"the same at commit {args.base}", "value": rows[0][f"{args.base} (s)"],
                   "unit": "s for odms-data --help"}, rows, {"odms_data_modules_loaded_base_here": loaded})


if __name__ == "__main__":
    main()
