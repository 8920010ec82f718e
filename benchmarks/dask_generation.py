"""Throughput of generating on Dask clusters of 2 single-threaded workers against local `--workers 2`.

Run by hand: `python benchmarks/dask_generation.py [--count 20000] [--repeat 3]` (needs the dask
extra). Every configuration runs `odms-data generate` in a subprocess (standard preset, n = 10,
480x640, Zarr, default shard size), so all pay the same start-up. The clusters are started once
beforehand, as real clusters would be, and each one's start-up (until its 2 workers have joined
and made a first shard: their first imports) is reported apart from the throughput: a default
deployment (`dask scheduler` and `dask worker --nworkers 2 --nthreads 1` processes, the workers
under Dask's nanny, which sets MALLOC_TRIM_THRESHOLD_=65536 in them), the same without the nanny,
a LocalCluster, and a LocalCluster whose workers run without Dask's statistical profiler (a
setting of the user's cluster, docs/DISTRIBUTED.md). Runs alternate between the configurations,
and the median of `--repeat` runs is reported, so a load that drifts during the run affects all
alike; CPU-seconds are exact (Linux): those of every process of the command's tree, its workers
included, and of the cluster's processes (a LocalCluster's workers; its scheduler and nannies run
in this process). The overhead of an engine is `1 - ratio`. All stores must have the same digest.
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
from collections.abc import Callable
from contextlib import ExitStack, contextmanager
from pathlib import Path
from typing import Any

import dask
import psutil

# run as a script, this file's own folder comes first on sys.path, where its name hides the package
sys.path[:] = [p for p in sys.path if Path(p or ".").resolve() != Path(__file__).resolve().parent]
from distributed import Client, LocalCluster  # noqa: E402

sys.path.append(str(Path(__file__).resolve().parent))  # last: nothing here shadows a package
import _results  # noqa: E402

DASK = Path(sys.executable).with_name("dask")
LOCAL_CLUSTERS = {  # LocalClusters by name, and the Dask settings of each
    "dask LocalCluster": {},
    "dask LocalCluster, profiler off": {"distributed.worker.profile.enabled": False},
}


def tree_cpu(pids: list[int]) -> tuple[float, float]:
    """CPU-seconds so far of these processes and all their descendants, and of their main threads
    alone: a Dask process's event loop (heartbeats, the profiler, messages), its tasks running in
    other threads."""
    total = loop = 0.0
    for pid in pids:
        try:
            root = psutil.Process(pid)
            for p in [root, *root.children(recursive=True)]:
                t = p.cpu_times()
                total += t.user + t.system
                loop += sum(t.user_time + t.system_time for t in p.threads() if t.id == p.pid)
        except psutil.Error:
            pass
    return total, loop


# Runs a command as its only child and reaps every process of its tree, its fork server's workers
# included (this process adopts them as they are orphaned: Linux's child subreaper), so that the
# wait4 of this process returns the whole tree's CPU, exactly.
REAPER = """import ctypes, os, subprocess, sys
ctypes.CDLL(None, use_errno=True).prctl(36, 1, 0, 0, 0)  # PR_SET_CHILD_SUBREAPER
code = subprocess.call(sys.argv[1:])
while True:
    try:
        os.wait()
    except ChildProcessError:
        sys.exit(code)
"""


def run(args: list[str], cluster_pids: list[int]) -> tuple[float, float, float, str]:
    """Wall seconds, CPU-seconds (the command and every process of its tree, and the cluster's),
    those of the cluster's event loops (`tree_cpu`) and the digest of one `generate`. The command
    does not reap its fork server, so its workers' CPU would never reach its own RUSAGE_CHILDREN:
    it runs under REAPER, which reaps them all."""
    (k0, loop0), t = tree_cpu(cluster_pids), time.perf_counter()
    with tempfile.TemporaryFile("w+") as out, tempfile.TemporaryFile("w+") as err:
        command = [sys.executable, "-I", "-c", REAPER, sys.executable, "-m", "odms_data.cli", "generate",
                   *args]
        proc = subprocess.Popen(command, stdout=out, stderr=err, text=True)
        _, status, usage = os.wait4(proc.pid, 0)
        proc.returncode = os.waitstatus_to_exitcode(status)
        secs = time.perf_counter() - t
        out.seek(0)
        err.seek(0)
        stdout, stderr = out.read(), err.read()
    k1, loop1 = tree_cpu(cluster_pids)
    if proc.returncode:
        raise SystemExit(f"odms-data generate {' '.join(args)} failed: {stderr.strip()}")
    cpu = usage.ru_utime + usage.ru_stime + k1 - k0
    return secs, cpu, loop1 - loop0, stdout.rsplit("digest ", 1)[1].split()[0]


@contextmanager
def deployment(tmp: Path, nanny: bool):
    """A `dask scheduler` process and 2 single-threaded workers: one `dask worker --nworkers 2`
    (nannies) or two `dask worker --no-nanny`; yields the address and the processes' ids."""
    file = tmp / f"scheduler-{nanny}.json"
    log = open(tmp / f"dask-{nanny}.log", "w")  # noqa: SIM115  # closed with the processes
    quiet = {"stdout": log, "stderr": subprocess.STDOUT}
    common = ["--no-dashboard", "--scheduler-file", file]
    procs = [subprocess.Popen([DASK, "scheduler", "--host", "127.0.0.1", "--port", "0", *common], **quiet)]
    workers = [["--nworkers", "2", "--nanny"]] if nanny else [["--no-nanny"]] * 2
    procs += [subprocess.Popen([DASK, "worker", "--nthreads", "1", *w, *common], **quiet) for w in workers]
    try:
        while not file.exists():
            time.sleep(0.1)
        time.sleep(0.5)  # written whole
        address = json.loads(file.read_text())["address"]
        with Client(address, timeout=60) as client:
            client.wait_for_workers(2, timeout=120)
        yield address, [p.pid for p in procs]
    finally:
        for p in reversed(procs):
            p.terminate()
            p.wait(30)
        log.close()


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--count", type=int, default=20000)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--url", action="store_true", help="also write a file:// URL on the nanny deployment")
    ap.add_argument("--local-cluster-only", action="store_true",
                    help="compare with a LocalCluster alone (no `dask scheduler`/`dask worker` deployments)")
    _results.add_options(ap)
    a = ap.parse_args()
    tmp = Path(tempfile.mkdtemp())
    times: dict[str, list[tuple[float, float, float]]] = {}
    digests = set()
    start_up: dict[str, float] = {}
    try:
        with ExitStack() as stack:
            def started(name: str, start: Callable[[], Any]) -> Any:
                t = time.perf_counter()
                value = stack.enter_context(start())
                start_up[name] = time.perf_counter() - t
                return value

            configs: dict[str, tuple[list[str], list[int]]] = {
                "local --workers 2": (["-o", str(tmp / "local.zarr"), "--workers", "2"], [])}
            if not a.local_cluster_only:
                nanny, nanny_pids = started("dask worker (nanny)", lambda: deployment(tmp, nanny=True))
                bare, bare_pids = started("dask worker --no-nanny", lambda: deployment(tmp, nanny=False))
                configs["dask worker (nanny)"] = (["-o", str(tmp / "nanny.zarr"), "--scheduler", nanny],
                                                  nanny_pids)
                configs["dask worker --no-nanny"] = (["-o", str(tmp / "bare.zarr"), "--scheduler", bare],
                                                     bare_pids)
                if a.url:
                    configs["dask (nanny) -> file://"] = (
                        ["-o", f"file://{tmp}/url.zarr", "--scheduler", nanny], nanny_pids)
            for name, config in LOCAL_CLUSTERS.items():
                with dask.config.set(config):  # copied into its workers as they start
                    cluster = started(name, lambda: LocalCluster(
                        n_workers=2, processes=True, threads_per_worker=1, dashboard_address=":0"))
                configs[name] = (["-o", str(tmp / f"{len(configs)}.zarr"), "--scheduler",
                                  cluster.scheduler_address],
                                 [w.process.pid for w in cluster.workers.values()])
            for name, (args, pids) in configs.items():
                if name in start_up:  # a cluster: its workers' first imports are part of its start-up
                    start_up[name] += run(["-n", "512", "--overwrite", *args], pids)[0]
            print("clusters' start-up (not counted below): "
                  + ", ".join(f"{k} {v:.1f} s" for k, v in start_up.items()))
            for _ in range(a.repeat):
                for name, (args, pids) in configs.items():
                    secs, cpu, loop, digest = run(["-n", str(a.count), "--overwrite", *args], pids)
                    times.setdefault(name, []).append((secs, cpu, loop))
                    digests.add(digest)
    finally:
        shutil.rmtree(tmp)
    if len(digests) != 1:
        raise SystemExit(f"digests differ between configurations: {sorted(digests)}")
    print(f"{a.count} examples, median of {a.repeat} runs each; digest {digests.pop()}; "
          f"load average {psutil.getloadavg()[0]:.1f} on {psutil.cpu_count()} CPUs")
    base = a.count / statistics.median(s for s, _, _ in times["local --workers 2"])
    base_cpu = a.count / statistics.median(c for _, c, _ in times["local --workers 2"])
    print(f"{'configuration':32} {'ex/s':>7} {'x local':>8} {'ex/CPU-s':>9} {'x local':>8} "
          f"{'loops CPU-s/1000':>16} {'start-up':>9}   runs (s)")
    rows = []
    for name, runs in times.items():
        rate = a.count / statistics.median(s for s, _, _ in runs)
        per_cpu = a.count / statistics.median(c for _, c, _ in runs)
        loops = 1000 / a.count * statistics.median(k for _, _, k in runs) if configs[name][1] else None
        up = start_up.get(name)
        print(f"{name:32} {rate:7.0f} {rate / base:8.2f} {per_cpu:9.0f} {per_cpu / base_cpu:8.2f} "
              f"{'' if loops is None else f'{loops:.3f}':>16} {'' if up is None else f'{up:.1f} s':>9}   "
              f"{' '.join(f'{s:.1f}' for s, _, _ in runs)}")
        rows.append({"configuration": name, "examples/s": rate, "x local": rate / base,
                     "examples/CPU-s": per_cpu, "x local (CPU)": per_cpu / base_cpu,
                     "cluster event loops CPU-s/1000 examples": loops, "cluster start-up s (apart)": up,
                     "runs (s)": " ".join(f"{s:.1f}" for s, _, _ in runs)})
    _results.save(a, f"Generating on Dask clusters against local workers ({a.count} examples, median of "
                  f"{a.repeat} runs)", {"what": "local `generate --workers 2`", "value": base_cpu,
                                        "unit": "examples/CPU-s"}, rows)


if __name__ == "__main__":
    main()
