"""Worker processes start warm and exit with the process that started them, even when it is
SIGKILLed."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

LOADER = """
import sys
from odms_data.loaders import Transform, stream_batches
if __name__ == "__main__":
    batches = iter(stream_batches(8, 1000, transform=Transform(size=(32, 32)), workers=2))
    next(batches)
    print("started", flush=True)
    sys.stdin.read()  # until killed
"""

OPENCV = """
import sys
import cv2
import numpy as np
cv2.setNumThreads(3)  # the user's own setting
from odms_data.importers import mask_files, synthia
from odms_data.loaders import Transform
from odms_data.parallel import worker_pool
from odms_data.simulate.generate_store import generate
from odms_data.simulate.params import GeneratorParams
from odms_data.store.masks import mask_stats

def threads():
    return cv2.getNumThreads()

if __name__ == "__main__":
    generate(sys.argv[1], 2, GeneratorParams(image_size=(60, 80), sizes=(20,)), seed=1, workers=1)
    mask_stats(np.ones((4, 4), bool))
    with worker_pool(1) as pool:
        print(cv2.getNumThreads(), pool.submit(threads).result(timeout=60))
"""


def state(pid: int) -> tuple[str, int] | None:
    """(state letter, parent pid) of a process, or None once it is gone."""
    try:
        fields = Path(f"/proc/{pid}/stat").read_text().rsplit(") ", 1)[1].split()
    except (FileNotFoundError, IndexError):
        return None
    return fields[0], int(fields[1])


def alive(pid: int) -> bool:
    """Running (a zombie waiting for init to reap it counts as gone)."""
    s = state(pid)
    return s is not None and s[0] != "Z"


def descendants(pid: int) -> list[int]:
    found = [int(p.name) for p in Path("/proc").iterdir() if p.name.isdigit()]
    children = [p for p in found if (state(p) or ("", 0))[1] == pid]
    return children + [d for c in children for d in descendants(c)]


def kill_and_wait(parent: subprocess.Popen, workers: list[int], shm_before: set[str]) -> None:
    parent.send_signal(signal.SIGKILL)
    parent.wait()
    deadline = time.monotonic() + 20
    while any(alive(p) for p in workers) or set(os.listdir("/dev/shm")) - shm_before:
        if time.monotonic() > deadline:
            break
        time.sleep(0.1)


def test_loader_workers_and_their_blocks_go_when_the_parent_is_killed():
    before = set(os.listdir("/dev/shm"))
    parent = subprocess.Popen(
        [sys.executable, "-c", LOADER], stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True
    )
    assert parent.stdout.readline().strip() == "started"
    workers = descendants(parent.pid)  # multiprocessing's resource tracker and fork server, two workers
    assert len(workers) == 4 and all(alive(p) for p in workers)
    assert set(os.listdir("/dev/shm")) - before  # the blocks carrying batches
    kill_and_wait(parent, workers, before)
    assert not any(alive(p) for p in workers)
    assert not set(os.listdir("/dev/shm")) - before  # removed by the resource tracker
    parent.stdin.close()
    parent.stdout.close()


def test_generate_workers_go_when_the_command_is_killed(tmp_path):
    cli = Path(sys.executable).with_name("odms-data")
    command = [cli, "generate", "-n", "1000000", "--workers", "2", "-o", tmp_path / "big.zarr"]
    parent = subprocess.Popen(command, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    deadline = time.monotonic() + 60
    while len(workers := descendants(parent.pid)) < 4 and time.monotonic() < deadline:
        time.sleep(0.1)
    assert len(workers) == 4
    kill_and_wait(parent, workers, set(os.listdir("/dev/shm")))
    assert not any(alive(p) for p in workers)


# --- ordered_map: the one ordered, bounded fan-out --------------------------------------------

def _slow_square(x: int) -> int:
    time.sleep(0.02 * (5 - x % 5))  # later items finish first
    return x * x


def test_ordered_map_keeps_item_order_and_its_bound():
    from concurrent.futures import Future, ThreadPoolExecutor

    from odms_data.parallel import ordered_map

    in_flight, most = 0, 0

    with ThreadPoolExecutor(4) as pool:
        def submit(x: int) -> Future:
            nonlocal in_flight, most
            in_flight += 1
            most = max(most, in_flight)
            return pool.submit(_slow_square, x)

        def collect(f: Future) -> int:
            nonlocal in_flight
            in_flight -= 1
            return f.result()

        assert list(ordered_map(submit, collect, range(12), 3, print)) == [x * x for x in range(12)]
    assert most == 3


def test_ordered_map_asks_a_callable_bound_at_every_top_up_and_abandons_the_rest_when_stopped():
    from odms_data.parallel import ordered_map

    bounds = iter([1, 2, 4, 4, 4, 4])
    submitted, abandoned = [], []

    def submit(x: int) -> int:
        submitted.append(x)
        return x

    results = ordered_map(submit, lambda h: h * 10, range(100), lambda: next(bounds), abandoned.extend)
    assert [next(results) for _ in range(3)] == [0, 10, 20]
    assert submitted == [0, 1, 2, 3, 4, 5, 6]  # at most 1, then 2, then 4 pending after each top-up
    results.close()
    assert abandoned == [3, 4, 5, 6]


WORKER_DIES_AS_ITS_POOL_ENDS = """
import os, signal, threading, time
from odms_data.parallel import end_pool, worker_pool

if __name__ == "__main__":
    pool = worker_pool(1)
    worker = pool.submit(os.getpid).result()
    futures = [pool.submit(time.sleep, 2)] + [pool.submit(int) for _ in range(6)]
    while not futures[0].running():  # handed to the worker: it dies working
        time.sleep(0.01)
    threading.Timer(0.5, os.kill, (worker, signal.SIGKILL)).start()  # as a stop to the whole group does
    end_pool(pool)
    print(*sorted({"cancelled" if f.cancelled() else type(f.exception()).__name__ for f in futures}))
"""


def test_a_pool_ended_while_its_worker_dies_prints_nothing():
    """Work not started is cancelled by the pool's own thread: a cancel from the caller raced that
    thread failing every pending future when the worker died, and Python 3.11 printed its
    InvalidStateError traceback."""
    p = subprocess.run([sys.executable, "-c", WORKER_DIES_AS_ITS_POOL_ENDS], capture_output=True,
                       text=True, timeout=120)
    # the one working dies with the pool; the rest are cancelled (but one the pool had queued for it)
    assert (p.returncode, p.stdout, p.stderr) == (0, "BrokenProcessPool cancelled\n", ""), p.stderr


def _kernel_loaded(_: int) -> bool:
    """Whether this process has the shard task's packing kernel compiled or loaded (this test
    module does not import the renderer, so only the fork server's preload can have)."""
    shards = sys.modules.get("odms_data.simulate.shards")
    return shards is not None and bool(shards._pack_boxes.signatures)


def test_workers_start_with_the_renderer_and_its_kernels_loaded():
    from odms_data.parallel import worker_pool

    with worker_pool(2) as pool:
        assert list(pool.map(_kernel_loaded, range(4))) == [True] * 4


# --- how many workers a job is worth ----------------------------------------------------------

def test_workers_are_started_only_for_enough_work():
    from odms_data.parallel import WORK_PER_WORKER_S, workers_for

    assert workers_for(0.0, 8) == workers_for(WORK_PER_WORKER_S * 1.9, 8) == 1
    assert workers_for(WORK_PER_WORKER_S * 2, 8) == 2
    assert workers_for(WORK_PER_WORKER_S * 100, 8) == 8
    assert workers_for(WORK_PER_WORKER_S * 100, 1) == 1


def test_generate_chooses_workers_by_the_work_unless_told(tmp_path):
    """2,000 examples run in-process by default, 4,000 and 100,000 on one worker per core (2 here);
    `workers` given is obeyed."""
    import multiprocessing

    from odms_data.parallel import workers_for
    from odms_data.simulate.generate_store import generate, work_seconds
    from odms_data.simulate.params import preset

    standard = preset("standard")
    assert workers_for(work_seconds(2000, standard), 2) == 1
    assert workers_for(work_seconds(4000, standard), 2) == 2
    assert workers_for(work_seconds(100_000, standard), 2) == 2
    small = preset("standard", image_size=(60, 80), sizes=(20,))
    alive: list[int] = []
    progress = lambda _: alive.append(len(multiprocessing.active_children()))  # noqa: E731
    generate(str(tmp_path / "auto.zarr"), 16, small, 0, examples_per_shard=4, progress=progress)
    assert alive == [0, 0, 0, 0]
    alive.clear()
    generate(str(tmp_path / "two.zarr"), 16, small, 0, workers=2, examples_per_shard=4, progress=progress)
    assert alive and min(alive) == 2


HANDS_OUT = """
import sys
from odms_data.simulate.generate_store import generate
from odms_data.simulate.params import preset
small = preset("standard", image_size=(60, 80), sizes=(20,))
generate(sys.argv[1], 16, small, 0, workers=2, examples_per_shard=4)
print(" ".join(sorted(m for m in ("numba", "cv2") if m in sys.modules)) or "neither")
"""


def test_the_process_handing_out_shard_tasks_does_not_import_the_renderer(tmp_path):
    run = subprocess.run([sys.executable, "-c", HANDS_OUT, str(tmp_path / "s.zarr")], capture_output=True,
                         text=True)
    assert run.returncode == 0, run.stderr
    assert run.stdout.strip() == "neither"
    assert (tmp_path / "s.zarr" / "zarr.json").is_file()


def test_workers_import_the_callers_odms_data_not_the_current_folders(tmp_path):
    """Run from a folder holding another odms_data (a clone, say), the workers use the caller's."""
    decoy = tmp_path / "odms_data"
    decoy.mkdir()
    (decoy / "__init__.py").write_text("raise RuntimeError('the decoy odms_data was imported')\n")
    command = Path(sys.executable).with_name("odms-data")
    r = subprocess.run([str(command), "generate", "-n", "4", "--examples-per-shard", "2", "--workers", "2",
                        "--param", "image_size=[48,64]", "-o", "out.zarr"],
                       capture_output=True, text=True, cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    assert "decoy" not in r.stderr and (tmp_path / "out.zarr").is_dir()


CTRL_C_AS_THE_FORK_SERVER_STARTS = """
import os, signal
import multiprocessing.util as util
from odms_data.parallel import _start_fork_server

signal.signal(signal.SIGINT, signal.default_int_handler)  # as in a terminal, also under a runner
# that started this process with SIGINT ignored (a pytest-xdist worker does)
spawn = util.spawnv_passfds

def spawn_then_ctrl_c(path, args, passfds):
    pid = spawn(path, args, passfds)
    if "multiprocessing.forkserver" in " ".join(map(str, args)):  # the fork server has just started
        os.kill(os.getpid(), signal.SIGINT)
    return pid

util.spawnv_passfds = spawn_then_ctrl_c
try:
    _start_fork_server()
except KeyboardInterrupt:
    print("stopped")
else:
    print("ran on")
"""


def test_a_ctrl_c_as_the_fork_server_starts_stops_the_caller(tmp_path):
    """A real SIGINT at the moment the fork server has been started, before the caller goes on:
    the caller stops (it is not lost while the server is shielded from it)."""
    r = subprocess.run([sys.executable, "-c", CTRL_C_AS_THE_FORK_SERVER_STARTS], cwd=tmp_path,
                       capture_output=True, text=True, timeout=120)
    assert r.stdout.strip() == "stopped", r.stdout + r.stderr
    assert "Traceback" not in r.stderr, r.stderr  # the server, loading the kernels, did not get it


MARKER_MODULE = """
import os, sys
here = os.path.dirname(os.path.abspath(__file__))
open(os.path.join(here, "RAN"), "a").write(f"{os.getpid()} {sys.argv[:2]}\\n")
del sys.modules[__name__]
sys.path = [p for p in sys.path if os.path.abspath(p or ".") != here]
import multiprocessing  # the real one, so that the command goes on and only the marker tells
"""


def test_no_child_process_imports_from_the_folder_a_command_runs_in(tmp_path):
    """A `multiprocessing.py` in the working folder runs in no process odms-data starts: the
    resource tracker, the fork server, pool workers (generate, import) and DataLoader workers
    (train, predict)."""
    from importers.test_import_recording import write_recording

    rec = write_recording(tmp_path / "rec")
    work = tmp_path / "work"
    work.mkdir()
    (work / "multiprocessing.py").write_text(MARKER_MODULE)
    command = str(Path(sys.executable).with_name("odms-data"))
    small = ["--param", "image_size=[48,64]"]
    runs = [
        ["generate", "-n", "12", "--examples-per-shard", "4", "--workers", "2",
         *small, "-o", "val.zarr"],
        ["import", "recording", str(rec["masks"]), "--positions", str(rec["csv"]), "--workers", "2",
         "-o", "cup.zarr"],
        ["train", "--model", "dbox", "-o", "dbox", "--val", "val.zarr", "--iterations", "2", "--batch-size",
         "4", "--val-every", "2", "--seed", "3"],  # its default workers
        ["train", "--model", "odn-d", "-o", "odn", "--val", "val.zarr", "--iterations", "2", "--batch-size",
         "2", "--val-every", "2", "--workers", "2", "--seed", "3"],
        ["predict", "odn", "--data", "val.zarr", "--workers", "2", "-o", "odn.csv"],
    ]
    for args in runs:
        r = subprocess.run([command, *args], cwd=work, capture_output=True, text=True, timeout=600)
        assert r.returncode == 0, (args, r.stderr)
        assert not (work / "RAN").exists(), (args, (work / "RAN").read_text())


SPAWNING = {  # names that start a process; only parallel.py and the command line's start may use them
    "ProcessPoolExecutor", "Pool", "Process", "get_context", "set_start_method", "ensure_running",
    "fork", "forkpty", "posix_spawn", "spawnv", "spawnve", "execv", "execve", "Popen", "run", "call",
    "check_call", "check_output", "system", "PYTHONSAFEPATH",
}
SPAWNING_MODULES = {"multiprocessing", "subprocess", "concurrent.futures"}


def test_only_parallel_starts_child_processes_and_the_command_line_makes_them_safe():
    """No module but parallel.py imports a process-starting API (or names PYTHONSAFEPATH), and the
    command line calls parallel.safe_children before running any command."""
    import ast
    import inspect

    from owner_ast import nodes_outside

    from odms_data.cli import OdmsGroup

    found = []
    for name, node in nodes_outside("parallel.py"):
        if isinstance(node, ast.ImportFrom) and (node.module or "").split(".")[0] in {
                m.split(".")[0] for m in SPAWNING_MODULES} | {"os"}:
            found += [f"{name}: from {node.module} import {a.name}" for a in node.names if a.name in SPAWNING]
        elif isinstance(node, ast.Import):
            found += [f"{name}: import {a.name}" for a in node.names
                      if a.name in SPAWNING_MODULES | {"multiprocessing.context",
                                                       "multiprocessing.forkserver"}]
        elif (isinstance(node, ast.Attribute) and node.attr in SPAWNING and isinstance(node.value, ast.Name)
              and node.value.id in {"os", "multiprocessing", "subprocess"}):
            found.append(f"{name}: {node.value.id}.{node.attr}")
        elif isinstance(node, ast.Constant) and node.value == "PYTHONSAFEPATH":
            found.append(f"{name}: PYTHONSAFEPATH")
    assert found == []
    main = ast.parse(inspect.getsource(OdmsGroup.main).strip().replace("\n    ", "\n"))
    assert "safe_children" in {n.func.id for n in ast.walk(main)
                               if isinstance(n, ast.Call) and isinstance(n.func, ast.Name)}


def test_opencvs_threads_stay_the_callers_and_workers_get_one(tmp_path):
    """Importing odms-data and generating in the caller's process leave OpenCV's thread count (the
    whole process's) as the caller set it; the workers odms-data starts run OpenCV on one thread."""
    script = tmp_path / "opencv_threads.py"
    script.write_text(OPENCV)
    r = subprocess.run([sys.executable, str(script), str(tmp_path / "s.zarr")], capture_output=True,
                       text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    assert r.stdout.split() == ["3", "1"]


def test_the_command_line_runs_opencv_on_one_thread():
    """A command's own process (and every child it starts, through the environment) runs OpenCV on
    one thread, unless the user chose a count."""
    code = ("from odms_data.cli import main\ntry:\n    main(['info', '--help'])\n"
            "except SystemExit:\n    pass\nimport cv2\nprint(cv2.getNumThreads())")
    env = {k: v for k, v in os.environ.items() if k != "OPENCV_FOR_THREADS_NUM"}
    for chosen, expect in ((None, "1"), ("2", "2")):
        extra = {"OPENCV_FOR_THREADS_NUM": chosen} if chosen else {}
        r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env={**env, **extra},
                           timeout=120)
        assert r.stdout.split()[-1] == expect, r.stderr
