"""Throughput of generating on a Dask LocalCluster of 2 workers against local `--workers 2`.

Run by hand: `python benchmarks/dask_generation.py [--count 4000] [--repeat 3]` (needs the dask
extra). Both configurations run `odms-data generate` in a subprocess (standard preset, n = 10,
480x640, Zarr, default shard size), so both pay the same start-up; the LocalCluster
(processes, 1 thread each) is started once beforehand, as a real cluster would be, and its
start-up is reported apart. Runs alternate between the configurations, and the median of
`--repeat` runs is reported, so a load that drifts during the run affects both alike. The
overhead of the engine is `1 - ratio`. Both stores must have the same digest.
"""

from __future__ import annotations

import argparse
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

# run as a script, this file's own folder comes first on sys.path, where its name hides the package
sys.path[:] = [p for p in sys.path if Path(p or ".").resolve() != Path(__file__).resolve().parent]
from distributed import LocalCluster  # noqa: E402


def run(args: list[str]) -> tuple[float, str]:
    """Wall seconds and the printed digest of one `odms-data generate`."""
    t = time.perf_counter()
    out = subprocess.run([sys.executable, "-m", "odms_data.cli", "generate", *args],
                         capture_output=True, text=True)
    secs = time.perf_counter() - t
    if out.returncode:
        raise SystemExit(f"odms-data generate {' '.join(args)} failed: {out.stderr.strip()}")
    return secs, out.stdout.rsplit("digest ", 1)[1].split()[0]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--count", type=int, default=4000)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--url", action="store_true", help="also write a file:// URL on the cluster")
    a = ap.parse_args()
    tmp = Path(tempfile.mkdtemp())
    t = time.perf_counter()
    cluster = LocalCluster(n_workers=2, processes=True, threads_per_worker=1, dashboard_address=":0")
    print(f"LocalCluster(2 workers) start-up: {time.perf_counter() - t:.1f} s (not counted below)")
    configs = {
        "local --workers 2": ["-o", str(tmp / "local.zarr"), "--workers", "2"],
        "dask LocalCluster 2": ["-o", str(tmp / "dask.zarr"), "--scheduler", cluster.scheduler_address],
    }
    if a.url:
        configs["dask -> file:// URL"] = ["-o", f"file://{tmp}/url.zarr", "--scheduler",
                                          cluster.scheduler_address]
    times: dict[str, list[float]] = {name: [] for name in configs}
    digests = set()
    try:
        for _ in range(a.repeat):
            for name, args in configs.items():
                secs, digest = run(["-n", str(a.count), "--overwrite", *args])
                times[name].append(secs)
                digests.add(digest)
    finally:
        cluster.close()
        shutil.rmtree(tmp)
    if len(digests) != 1:
        raise SystemExit(f"digests differ between configurations: {sorted(digests)}")
    base = a.count / statistics.median(times["local --workers 2"])
    print(f"{a.count} examples, median of {a.repeat} runs each; digest {digests.pop()}")
    print(f"{'configuration':22} {'ex/s':>7} {'x local':>8}   runs (s)")
    for name, secs in times.items():
        rate = a.count / statistics.median(secs)
        print(f"{name:22} {rate:7.0f} {rate / base:8.2f}   {' '.join(f'{s:.1f}' for s in secs)}")


if __name__ == "__main__":
    main()
