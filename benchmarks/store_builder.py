"""Writing stores through the one store builder against the code before it, in one run.

Run by hand: `python benchmarks/store_builder.py --before PATH [--repeat 3]`, PATH a checkout of
the code before the builder (`git worktree add PATH <commit>`). Every command runs as `odms-data`
in a subprocess, with this tree's package or the one at PATH first on the path, taking turns
(before, after, before, ...) so that a load that drifts affects both alike; the median wall time
of `--repeat` runs is reported. The commands: `generate` of masks (standard preset, 480x640,
n = 10, 50 examples a task) on 2 local workers; `generate --boxes` (before: always in one
process; after: in one process, the default, and on 2 workers); `import
recording` of a recording of PNG masks on 2 workers; `convert` of the generated store to HDF5;
and `generate` of masks on a Dask LocalCluster of 2 single-threaded worker processes against 2
local workers (the cluster started once, beforehand, as a real cluster is). Each command's
stores must have the same digest before and after.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

# each command runs in a subprocess, with the package of the tree under test first on its path
sys.path.append(str(Path(__file__).resolve().parent))
import _results  # noqa: E402
from untrusted_checks import write_recording  # noqa: E402

HERE = Path(__file__).resolve().parent.parent


def odms(tree: Path, args: list[str], cwd: Path) -> tuple[float, str]:
    """Wall seconds and the `--json` digest of `odms-data ARGS` run with `tree`'s package."""
    env = {**os.environ, "PYTHONPATH": str(tree)}
    t = time.perf_counter()
    out = subprocess.run([sys.executable, "-m", "odms_data.cli", *args, "--json"], cwd=cwd, env=env,
                         capture_output=True, text=True)
    seconds = time.perf_counter() - t
    if out.returncode:
        raise SystemExit(f"{tree}: odms-data {' '.join(args)} failed: {out.stderr.strip()[-400:]}")
    record = json.loads(out.stdout[out.stdout.index("{"):])
    digest = record[0]["digest"] if isinstance(record, list) else record["digest"]
    return seconds, digest


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--before", type=Path, required=True, help="a checkout of the code before the builder")
    ap.add_argument("--masks", type=int, default=600, help="examples of masks generated (50 a task)")
    ap.add_argument("--boxes", type=int, default=30000, help="examples of boxes generated")
    ap.add_argument("--frames", type=int, default=600, help="frames of the imported recording")
    ap.add_argument("--repeat", type=int, default=3)
    _results.add_options(ap)
    a = ap.parse_args()
    from distributed import LocalCluster

    os.environ["PYTHONPATH"] = str(HERE)  # the cluster's workers run this tree's package
    sys.path.insert(0, str(HERE))  # (spawned, they take this process's path)
    tmp = Path(tempfile.mkdtemp())
    masks, csv = write_recording(tmp / "rec", a.frames)
    src = tmp / "src.zarr"
    odms(HERE, ["generate", "-n", str(a.masks), "-o", str(src), "--workers", "2"], tmp)
    gen = ["generate", "-n", str(a.masks), "-o", "m.zarr", "--overwrite", "--examples-per-shard", "50"]
    box = ["generate", "--boxes", "odmd", "-n", str(a.boxes), "-o", "b.zarr", "--overwrite"]
    commands = {  # name: (before's arguments, after's arguments)
        "generate masks, 2 workers": ([*gen, "--workers", "2"],) * 2,
        "generate --boxes, one worker": (box, [*box, "--workers", "1"]),
        "generate --boxes, 2 workers (before: one)": (box, [*box, "--workers", "2"]),
        "import recording, 2 workers": (["import", "recording", str(masks), "--positions", str(csv), "-o",
                                         "r.zarr", "--windows", "10", "--overwrite", "--workers", "2"],) * 2,
        "convert Zarr to HDF5": (["convert", str(src), "c.h5", "--overwrite"],) * 2,
    }
    times: dict[str, dict[str, list[float]]] = {c: {"before": [], "after": []} for c in commands}
    digests: dict[str, set[str]] = {c: set() for c in commands}
    dask_times: dict[str, list[float]] = {"local": [], "dask": []}
    with LocalCluster(n_workers=2, processes=True, threads_per_worker=1, dashboard_address=":0") as cluster:
        for _ in range(a.repeat):
            for name, (before, after) in commands.items():
                for which, tree, args in (("before", a.before, before), ("after", HERE, after)):
                    seconds, digest = odms(tree, args, tmp)
                    times[name][which].append(seconds)
                    digests[name].add(digest)
            on = cluster.scheduler_address
            for which, more in (("local", ["--workers", "2"]), ("dask", ["--scheduler", on])):
                seconds, digest = odms(HERE, [*gen, *more], tmp)
                dask_times[which].append(seconds)
                digests["generate masks, 2 workers"].add(digest)
    shutil.rmtree(tmp)
    different = [c for c, d in digests.items() if len(d) != 1]
    if different:
        raise SystemExit(f"the digests differ for {', '.join(different)}")
    rows = []
    for name, t in times.items():
        before, after = statistics.median(t["before"]), statistics.median(t["after"])
        rows.append({"command": name, "before s": before, "after s": after, "x before": before / after})
        print(f"{name:36} before {before:7.2f} s  after {after:7.2f} s  {before / after:5.2f} x")
    local, dask = statistics.median(dask_times["local"]), statistics.median(dask_times["dask"])
    rows.append({"command": "generate masks on a LocalCluster of 2 (x: local 2 workers' time over it)",
                 "before s": local, "after s": dask, "x before": local / dask})
    print(f"Dask LocalCluster of 2 {dask:.2f} s, local 2 workers {local:.2f} s: {local / dask:.2f} x")
    _results.save(a, "Writing stores through the one store builder, before and after",
                  {"what": "the same commands with the code before the store builder", "value": None,
                   "unit": "s"}, rows, {"counts": {"masks": a.masks, "boxes": a.boxes, "frames": a.frames}})


if __name__ == "__main__":
    main()
