"""The hostile catalogue: what a user who means harm, or has bad luck, gives the command line,
by class of broken promise (docs/ERRORS.md; issue 15), each with the promise it checks.

Every case runs one command in a fresh folder holding copies of what it needs and checks, besides
its own expectations, the promises every command keeps: the expected exit code; on an error one
line `odms-data: error: ...` (the last on stderr; only progress may come before it) naming what
the case says; no traceback and no warning; nothing changed in the folder on a failure, and on a
success nothing but the case's outputs; no `.partial` or `.lock` left.

tests/cli/test_hostile.py runs the catalogue in-process (click's CliRunner) except the cases
that need their own process (signals, a small disk, memory). Run by hand, it counts the cases
kept and broken per class for any checkout, each case in its own process:

    python tests/cli/hostile.py                       # this checkout
    python tests/cli/hostile.py --code /tmp/main-src  # another one (e.g. `git archive main`)

A small disk is a tmpfs of a few KiB mounted in a private mount namespace (`unshare -m`, or
`unshare -rm` without root); where neither works, RLIMIT_FSIZE (writes past a few KiB fail with
EFBIG instead of ENOSPC).
"""

from __future__ import annotations

import argparse
import gc
import hashlib
import json
import os
import resource
import shutil
import signal
import stat
import subprocess
import sys
import tempfile
import threading
import time
import warnings
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass, field
from functools import cache
from pathlib import Path

import cv2
import numpy as np

HERE = Path(__file__).resolve().parent
sys.path[:0] = [str(HERE), str(HERE.parent)]
if __name__ == "__main__" and "--code" in sys.argv:  # fixtures made by the checkout under test too
    sys.path.insert(0, sys.argv[sys.argv.index("--code") + 1])

from _stores import make_store  # noqa: E402
from broken_stores import DAMAGE, copy_store, make_valid  # noqa: E402

CLASSES = ("data loss", "unbounded work", "internal error", "misleading answer", "consistency")
HEADER = "split,example_id,d1"


@dataclass
class Result:
    rc: int
    out: str
    err: str
    seconds: float = 0.0
    max_rss_mb: float = 0.0
    leftovers: list[str] = field(default_factory=list)  # what a small disk held after the command


@dataclass
class Case:
    cls: str
    name: str
    args: list[str]
    needs: tuple[str, ...] = ()  # fixtures copied into the case folder
    setup: Callable[[Path], None] | None = None
    expect: int = 2
    says: tuple[str, ...] = ()  # fragments of the error line
    outputs: tuple[str, ...] = ()  # paths (relative) a success may create or change
    check: Callable[[Path, Result], None] | None = None
    process: bool = False  # needs its own process (signal, small disk, memory)
    disk_kib: int = 0  # the folder disk/ is a small filesystem of this size ...
    full: bool = False  # ... filled up before the command runs
    stop: tuple[int, str, float] | None = None  # (signal, file whose appearance starts a delay, delay s)
    timeout: float = 120.0


# --- fixtures -------------------------------------------------------------------------------

def _recording(root: Path, n: int = 6) -> None:
    masks = root / "rec"
    masks.mkdir()
    lines = ["frame,z,depth"]
    for i in range(n):
        z = 0.2 + 0.02 * i
        img = np.zeros((24, 32), np.uint8)
        cv2.circle(img, (16, 12), max(1, int(2 / z)), 255, -1)
        cv2.imwrite(str(masks / f"f{i}.png"), img)
        lines.append(f"f{i}.png,{z:.3f},{z + 0.1:.3f}")
    (root / "positions.csv").write_text("\n".join(lines) + "\n")


def make_fixtures(root: Path) -> Path:
    """Everything cases copy: valid stores of split `tiny`, its predictions, a recording, and
    the user's own files (photos, a thesis) that must never be harmed."""
    make_valid(root / "tiny.zarr")
    make_valid(root / "tiny.h5")
    make_valid(root / "other.zarr", split="other")
    rows = [f"tiny,tiny/{i:06d},{0.3 + 0.01 * i}" for i in range(4)]
    (root / "p.csv").write_text("\n".join([HEADER, *rows]) + "\n")
    examples = [{"z": [d, d + 0.1], "areas": [100, 64], "d1": d} for d in (0.2, 0.4, 0.5)]
    make_store(root / "normal-val.zarr", "normal-val", examples)  # an official split, for entries
    rows = [f"normal-val,normal-val/{i:03d},0.3" for i in range(3)]
    (root / "n.csv").write_text("\n".join([HEADER, *rows]) + "\n")
    _recording(root)
    (root / "photos").mkdir()
    for i in range(3):
        (root / "photos" / f"IMG_{i:04d}.jpg").write_bytes(bytes([i]) * 1000)
    (root / "thesis.pdf").write_bytes(b"%PDF-1.7 my thesis " * 100)
    (root / "old.csv").write_text("my old results\n")
    (root / "old.png").write_bytes(b"my old picture")
    (root / "old.json").write_text('{"mine": true}\n')
    (root / "empty").mkdir()
    return root


def _copy(src: Path, dst: Path) -> None:
    dst.parent.mkdir(parents=True, exist_ok=True)
    copy_store(src, dst)


def snapshot(root: Path) -> dict[str, str]:
    """relative path -> content hash (files) or 'dir'/'link', for everything under root."""
    out = {}
    for p in sorted(root.rglob("*")):
        rel = str(p.relative_to(root))
        if p.is_symlink():
            out[rel] = "link:" + os.readlink(p)
        elif p.is_dir():
            out[rel] = "dir"
        elif p.is_file():
            out[rel] = hashlib.sha256(p.read_bytes()).hexdigest()
    return out


# --- running --------------------------------------------------------------------------------

def run_inprocess(args: list[str], cwd: Path) -> Result:
    from click.testing import CliRunner

    from odms_data.cli import main

    here = os.getcwd()
    os.chdir(cwd)
    gc.collect()  # what earlier tests left for the collector warns now, not as this command's output
    t = time.perf_counter()
    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            r = CliRunner().invoke(main, args)
            gc.collect()  # and what this command left warns as its own
    finally:
        os.chdir(here)
    err = r.stderr + "".join(f"{w.category.__name__}: {w.message}\n" for w in caught)
    return Result(r.exit_code, r.stdout, err, time.perf_counter() - t)


@cache
def disk_method() -> str:
    """How this machine makes a small filesystem: 'unshare -m', 'unshare -rm' or 'rlimit'."""
    with tempfile.TemporaryDirectory() as d:
        for flags in ("-m", "-rm"):
            probe = ["unshare", flags, "sh", "-c", f"mount -t tmpfs -o size=64k tmpfs {d}"]
            try:
                if subprocess.run(probe, capture_output=True, timeout=20).returncode == 0:
                    return f"unshare {flags}"
            except (OSError, subprocess.TimeoutExpired):
                pass
    return "rlimit"


RLIMIT_BYTES = 64  # the file size limit standing in for a small disk where no tmpfs can be mounted


def run_process(case: Case, args: list[str], cwd: Path, code: Path | None) -> Result:
    """The command in its own process (`code`'s odms_data), with its peak memory."""
    import psutil

    env = dict(os.environ)
    if code is not None:
        env["PYTHONPATH"] = str(code)
    argv = [sys.executable, "-m", "odms_data.cli", *args]
    limit = 6 * 2**30

    def limits() -> None:
        resource.setrlimit(resource.RLIMIT_AS, (limit, limit))
        if case.disk_kib and disk_method() == "rlimit":
            resource.setrlimit(resource.RLIMIT_FSIZE, (RLIMIT_BYTES, RLIMIT_BYTES))

    listing = cwd.parent / f"{cwd.name}.disk"
    if case.disk_kib:
        (cwd / "disk").mkdir(exist_ok=True)
        if disk_method() != "rlimit":
            fill = "cat /dev/zero > disk/.filler 2> /dev/null; " if case.full else ""
            script = (f'mount -t tmpfs -o size="$1"k tmpfs disk || exit 99; {fill}shift; shift; "$@"; '
                      f'rc=$?; rm -f disk/.filler; ls -A disk > "{listing}"; exit $rc')
            argv = ["unshare", *disk_method().split()[1:], "sh", "-c", script, "sh",
                    str(case.disk_kib), "--", *argv]
    t = time.perf_counter()
    proc = subprocess.Popen(argv, cwd=cwd, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            preexec_fn=limits)
    streams: dict[str, bytes] = {}
    readers = [threading.Thread(target=lambda k, f: streams.__setitem__(k, f.read()), args=(k, f))
               for k, f in (("out", proc.stdout), ("err", proc.stderr))]
    for th in readers:
        th.start()
    timer = threading.Timer(case.timeout, proc.kill)
    timer.start()
    child = psutil.Process(proc.pid)
    peak = [0]

    def sample() -> None:  # the process tree's resident memory (wait4's counts the fork's copy of ours)
        while child.is_running() and child.status() != psutil.STATUS_ZOMBIE:
            try:
                tree = [child, *child.children(recursive=True)]
                peak[0] = max(peak[0], sum(p.memory_info().rss for p in tree))
            except psutil.Error:
                pass
            time.sleep(0.02)

    sampler = threading.Thread(target=sample, daemon=True)
    sampler.start()
    if case.stop:
        signum, trigger, delay = case.stop
        deadline = time.monotonic() + 60
        while (not (cwd / trigger).exists() and child.status() != psutil.STATUS_ZOMBIE
               and time.monotonic() < deadline):
            time.sleep(0.02)
        time.sleep(delay)
        if child.status() != psutil.STATUS_ZOMBIE:
            proc.send_signal(signum)
    sampler.join()
    proc.wait()
    killed = not timer.is_alive()
    timer.cancel()
    for th in readers:
        th.join()
    proc.stdout.close()
    proc.stderr.close()
    err = streams["err"].decode(errors="replace")
    err += f"\n(killed after {case.timeout:.0f} s)" if killed else ""
    result = Result(proc.returncode, streams["out"].decode(errors="replace"), err,
                    time.perf_counter() - t, peak[0] / 2**20)
    if listing.exists():
        result.leftovers = listing.read_text().split()
        listing.unlink()
    elif case.disk_kib and disk_method() == "rlimit":
        result.leftovers = [p.name for p in (cwd / "disk").iterdir()]
    return result


def run_case(case: Case, fixtures: Path, work: Path, *, code: Path | None = None,
             inprocess: bool = True) -> list[str]:
    """Run one case in a fresh folder under `work`; the broken promises (empty: all kept)."""
    cwd = work / case.name.replace("/", "_").replace(" ", "_")
    shutil.rmtree(cwd, ignore_errors=True)
    cwd.mkdir(parents=True)
    for need in case.needs:
        _copy(fixtures / need, cwd / need)
    if case.setup:
        case.setup(cwd)
    if case.disk_kib:
        (cwd / "disk").mkdir(exist_ok=True)
    before = snapshot(cwd)
    if inprocess and not case.process:
        r = run_inprocess(case.args, cwd)
    else:
        r = run_process(case, case.args, cwd, code)
    after = snapshot(cwd)
    broken = promises_broken(case, r, before, after)
    if case.check and not broken:
        try:
            case.check(cwd, r)
        except AssertionError as e:
            broken.append(f"check: {e}")
    if case.disk_kib and disk_method() == "rlimit":
        shutil.rmtree(cwd / "disk", ignore_errors=True)
    return broken


def promises_broken(case: Case, r: Result, before: dict[str, str], after: dict[str, str]) -> list[str]:
    broken = []
    lines = r.err.strip().splitlines()
    if r.rc != case.expect:
        broken.append(f"exit code {r.rc}, expected {case.expect}: {r.err.strip()[-300:]!r}")
    if "Traceback" in r.err or "Warning" in r.err or "warning" in r.err:
        broken.append(f"traceback or warning on stderr: {r.err.strip()[-300:]!r}")
    ours = [line for line in lines if line.startswith("odms-data:")]
    if r.rc == 2:
        if len(ours) != 1 or lines[-1] != ours[0] or not ours[0].startswith("odms-data: error: "):
            broken.append(f"not one 'odms-data: error:' line: {r.err.strip()[-300:]!r}")
        else:
            broken += [f"error does not say {s!r}: {ours[0]!r}" for s in case.says if s not in ours[0]]
    changed = {k for k in set(before) | set(after) if before.get(k) != after.get(k)}
    allowed = {k for k in changed if any(k == o or k.startswith(o + "/") for o in case.outputs)}
    if r.rc != 0 and changed:
        broken.append(f"a failure changed {sorted(changed)[:4]}")
    elif changed - allowed:
        broken.append(f"changed outside the outputs: {sorted(changed - allowed)[:4]}")
    litter = [k for k in after if before.get(k) != after[k] and (k.endswith((".partial", ".lock"))
                                                                 or ".partial/" in k)]
    litter += [f"disk/{x}" for x in r.leftovers]
    if litter:
        broken.append(f"left behind: {litter[:4]}")
    return broken


# --- helpers for the cases ------------------------------------------------------------------

def damaged(kind: str, store: str = "tiny.zarr") -> Callable[[Path], None]:
    return lambda cwd: DAMAGE[kind][1](cwd / store)


def write(rel: str, data: bytes | str) -> Callable[[Path], None]:
    def setup(cwd: Path) -> None:
        (cwd / rel).parent.mkdir(parents=True, exist_ok=True)
        (cwd / rel).write_bytes(data if isinstance(data, bytes) else data.encode())
    return setup


def steps(*fns: Callable[[Path], None]) -> Callable[[Path], None]:
    def setup(cwd: Path) -> None:
        for fn in fns:
            fn(cwd)
    return setup


def valid_store(rel: str) -> Callable[[Path, Result], None]:
    def check(cwd: Path, r: Result) -> None:
        from odms_data.store.validate import validate

        report = validate(str(cwd / rel))
        assert report.ok, report.problems
    return check


def file_is(rel: str, fixture: str) -> Callable[[Path, Result], None]:
    """The output `rel` now holds something else than the fixture it replaced, and is whole."""
    def check(cwd: Path, r: Result) -> None:
        assert (cwd / rel).is_file(), f"{rel} missing"
        assert (cwd / rel).read_bytes() != (FIXTURES / fixture).read_bytes(), f"{rel} not replaced"
    return check


def holds(test: Callable[[Path, Result], bool], what: str) -> Callable[[Path, Result], None]:
    def check(cwd: Path, r: Result) -> None:
        assert test(cwd, r), what
    return check


def strict_json(cwd: Path, r: Result) -> None:
    def refuse(const: str) -> None:
        raise AssertionError(f"JSON holds {const}")

    json.loads(r.out, parse_constant=refuse)


def imported_mask_not_empty(cwd: Path, r: Result) -> None:
    from odms_data.store.reader import open_store

    with open_store(str(cwd / "out.zarr")) as s:
        assert (s.area > 0).all(), f"empty masks imported: areas {s.area.tolist()}"


def quick(seconds: float, mib: float) -> Callable[[Path, Result], None]:
    def check(cwd: Path, r: Result) -> None:
        assert r.seconds < seconds, f"took {r.seconds:.1f} s"
        assert not r.max_rss_mb or r.max_rss_mb < mib, f"peak memory {r.max_rss_mb:.0f} MiB"
    return check


def started_at_once(cwd: Path, r: Result) -> None:
    assert "generating" in r.err, "no progress before the stop"


def rgba(alpha_only: bool) -> Callable[[Path], None]:
    """Every mask of the recording as RGBA: the object in the alpha channel only, or in colour and
    (differently) in alpha."""
    def setup(cwd: Path) -> None:
        for p in (cwd / "rec").glob("*.png"):
            m = cv2.imread(str(p), cv2.IMREAD_GRAYSCALE)
            colour = np.zeros_like(m) if alpha_only else 255 - m
            cv2.imwrite(str(p), np.dstack([colour, colour, colour, m]))
    return setup


def big_predictions(rows: int) -> Callable[[Path], None]:
    def setup(cwd: Path) -> None:
        block = "".join(f"tiny,tiny/{i:06d},0.5\n" for i in range(100_000))
        with open(cwd / "big.csv", "w") as f:
            f.write(HEADER + "\n")
            for _ in range(rows // 100_000):
                f.write(block)
    return setup


def long_line(cwd: Path) -> None:
    with open(cwd / "long.csv", "w") as f:
        f.write(HEADER + "\n")
        f.write("tiny,tiny/" + "x" * 50_000_000 + ",0.5\n")


# --- the catalogue --------------------------------------------------------------------------

G = ["generate", "-n", "3", "--workers", "1"]
TINY = ["--param", "image_size=[24,36]", "--param", "sizes=[12,20]"]
SCORE = ["score", "p.csv", "--data", "tiny.zarr"]
SHOW = ["show", "tiny.zarr", "tiny/000001"]
VOSDE = ["baseline", "vosde", "tiny.zarr", "--n-obs", "3"]  # its examples have 3 frames
REC = ["import", "recording", "rec", "--positions", "positions.csv", "--workers", "1"]
STORE_NEEDS = ("tiny.zarr", "p.csv")
D = "data loss"
U = "unbounded work"
I = "internal error"  # noqa: E741
M = "misleading answer"
C = "consistency"

CASES: list[Case] = []


def case(*args, **kwargs) -> None:
    CASES.append(Case(*args, **kwargs))


# Data loss: every file output refuses an existing path, replaces it only when asked, never
# turns a folder into a file, and leaves nothing half-written on a full disk.
FILE_OUTPUTS = {  # name -> (command up to the output option, option, fixture to replace, suffix)
    "score --entry": (["score", "n.csv", "--data", "normal-val.zarr", "--name", "Me"], "--entry", "old.json",
                      ".json"),
    "score --plot": (SCORE, "--plot", "old.png", ".png"),
    "baseline -o": (VOSDE, "-o", "old.csv", ".csv"),
    "show -o": (SHOW, "-o", "old.png", ".png"),
}
for what, (cmd, opt, old, suffix) in FILE_OUTPUTS.items():
    needs = (*STORE_NEEDS, "n.csv", "normal-val.zarr", old)
    case(D, f"{what}: an existing file is kept", [*cmd, opt, old], needs, says=(old, "--overwrite"))
    case(D, f"{what}: a folder is not a file", [*cmd, opt, "photos"], (*needs, "photos"),
         says=("photos", "folder"))
    if what == "score --entry":  # normal-val.zarr is not the official content: no entry is written
        case(M, f"{what}: a store only named like an official split", [*cmd, opt, old, "--overwrite"], needs,
             says=("normal-val.zarr", "digest"))
        continue
    case(D, f"{what}: --overwrite replaces it", [*cmd, opt, old, "--overwrite"], needs, expect=0,
         outputs=(old,), check=file_is(old, old))
    case(D, f"{what}: full disk, nothing left", [*cmd, opt, f"disk/out{suffix}"], needs,
         says=(f"disk/out{suffix}",), process=True, disk_kib=64, full=True)
STORE_OUTPUTS = {  # name -> command without the output
    "generate": [*G, *TINY, "-o"],
    "convert": ["convert", "tiny.zarr"],
    "import recording": [*REC, "-o"],
}
EXPORT = ["export", "tiny.zarr", "-o"]
EARLIER = write("hub/croissant.json", '{"creator": {"name": "odms-data 0.1"}}')
case(D, "export: --overwrite keeps a folder of photos", [*EXPORT, "photos", "--overwrite"],
     ("tiny.zarr", "photos"), says=("photos", "not an earlier export"))
case(D, "export: --overwrite keeps a thesis", [*EXPORT, "thesis.pdf", "--overwrite"],
     ("tiny.zarr", "thesis.pdf"), says=("thesis.pdf", "not an earlier export"))
case(D, "export: --overwrite keeps another tool's Croissant dataset", [*EXPORT, "hub", "--overwrite"],
     ("tiny.zarr",), setup=write("hub/croissant.json", '{"creator": {"name": "someone"}}'),
     says=("hub", "not an earlier export"))
case(D, "export: an earlier export is kept", [*EXPORT, "hub"], ("tiny.zarr",), setup=EARLIER,
     says=("hub", "already exists"))
case(D, "export: --overwrite replaces an earlier export", [*EXPORT, "hub", "--overwrite"], ("tiny.zarr",),
     setup=EARLIER, expect=0, outputs=("hub",),
     check=holds(lambda cwd, r: len(list(cwd.glob("hub/data/tiny/*.parquet"))) == 1, "no Parquet file"))
case(D, "export: --overwrite fills an empty folder", [*EXPORT, "empty", "--overwrite"],
     ("tiny.zarr", "empty"), expect=0, outputs=("empty",),
     check=holds(lambda cwd, r: (cwd / "empty/README.md").is_file(), "no card"))
case(D, "export: full disk, nothing left", [*EXPORT, "disk/hub"], ("tiny.zarr",), says=("disk/hub",),
     process=True, disk_kib=64, full=True)
case(D, "export: disk full mid-file, nothing left", ["export", "big.zarr", "-o", "disk/hub"],
     setup=lambda cwd: make_valid(cwd / "big.zarr", count=1000), says=("disk/hub", "no space"),
     process=True, disk_kib=64)
for what, cmd in STORE_OUTPUTS.items():
    needs = ("tiny.zarr", "rec", "positions.csv")
    case(D, f"{what}: --overwrite keeps a folder of photos", [*cmd, "photos", "--overwrite"],
         (*needs, "photos"), says=("photos", "not an odms-data store"))
    case(D, f"{what}: --overwrite keeps a thesis", [*cmd, "thesis.pdf", "--overwrite"],
         (*needs, "thesis.pdf"), says=("thesis.pdf", "not an odms-data store"))
    case(D, f"{what}: an existing store is kept", [*cmd, "tiny.h5"], (*needs, "tiny.h5"),
         says=("already exists",))
    case(D, f"{what}: --overwrite keeps a FIFO, without waiting on it", [*cmd, "pipe.h5", "--overwrite"],
         needs, setup=lambda cwd: os.mkfifo(cwd / "pipe.h5"), says=("pipe.h5", "is a FIFO"),
         check=holds(lambda cwd, r: stat.S_ISFIFO(os.lstat(cwd / "pipe.h5").st_mode), "the FIFO is gone"),
         process=True, timeout=60)
    case(D, f"{what}: --overwrite replaces a store", [*cmd, "other.zarr", "--overwrite"],
         (*needs, "other.zarr"), expect=0, outputs=("other.zarr",), check=valid_store("other.zarr"))
    case(D, f"{what}: --overwrite fills an empty folder", [*cmd, "empty", "--overwrite"],
         (*needs, "empty"), expect=0, outputs=("empty",), check=valid_store("empty"))
    for fmt in ("zarr", "h5"):
        case(D, f"{what}: full disk ({fmt}), nothing left", [*cmd, f"disk/out.{fmt}"], needs,
             says=(f"disk/out.{fmt}",), process=True, disk_kib=8)
for fmt in ("zarr", "h5"):  # the disk fills while shards are written, by two worker processes
    case(D, f"generate: disk full mid-way ({fmt}), nothing left",
         ["generate", "-n", "300", "--workers", "2", "-o", f"disk/g.{fmt}"],
         says=(f"disk/g.{fmt}", "no space"), process=True, disk_kib=256)
INSIDE = {"export": [*EXPORT, "tiny.zarr/hub"], "convert": ["convert", "tiny.zarr", "tiny.zarr/t.zarr"],
          "baseline -o": [*VOSDE, "-o", "tiny.zarr/v.csv"], "show -o": [*SHOW, "-o", "tiny.zarr/s.png"],
          "generate": [*G, *TINY, "-o", "tiny.zarr/x/g.h5"]}
for what, cmd in INSIDE.items():
    case(D, f"{what}: an output inside a store is refused", cmd, STORE_NEEDS, says=("inside the Zarr store",))
case(D, "convert: a failure leaves no folders it made", ["convert", "tiny.zarr", "new/dir/out.h5"],
     ("tiny.zarr",), setup=damaged("digest wrong"), says=("content digest",))
case(D, "generate: the default output is kept", [*G], setup=write("generated.zarr/x.txt", "mine"),
     says=("generated.zarr", "already exists"))

# Unbounded work from small input: checked early, memory bounded, a large count starts at once.
case(U, "score /dev/zero", ["score", "/dev/zero", "--data", "tiny.zarr"], ("tiny.zarr",),
     says=("is a device",), process=True, check=quick(30, 1024), timeout=60)
case(U, "score: 3 million rows for 4 examples", ["score", "big.csv", "--data", "tiny.zarr"], ("tiny.zarr",),
     setup=big_predictions(3_000_000), says=("more than 4 rows",), process=True, check=quick(30, 600))
case(U, "score: one line of 50 MB", ["score", "long.csv", "--data", "tiny.zarr"], ("tiny.zarr",),
     setup=long_line, says=("line 2 is longer",), process=True, check=quick(30, 600))
for param, say in [
    ("sizes=[1000000000]", "sizes must be"), ("perturb_std=1e9", "perturb_std must be"),
    ("image_size=[100000,100000]", "image_size must be"), ("d_max=1e400", "is too large"),
    ("bezier_radius=[1e9]", "bezier_radius must be"),
    ("curve_samples=100000000", "curve_samples must be"), ("n_points=[10000000]", "n_points must be"),
    ("spacing_tries=1000000000000", "spacing_tries must be"), ("n_obs=100000", "n_obs must be"),
]:
    case(U, f"generate --param {param}", [*G, "--param", param, "-o", "x.zarr"],
         says=(say, "<=") if "must be" in say else (say,), process=True, timeout=60)
for constant in ("d_max=Infinity", "d_min=NaN"):  # JSON has neither: safe_json refuses both
    case(U, f"generate --param {constant}", [*G, "--param", constant, "-o", "x.zarr"],
         says=(f"'{constant}': not valid JSON", "is not a JSON number"), process=True, timeout=60)
case(U, "generate: curve_samples x n_points bounded", [*G, "--param", "curve_samples=10000", "--param",
                                                        "n_points=[1000]", "-o", "x.zarr"],
     says=("curve_samples x the largest n_points must be <= 100000",), process=True, timeout=60)
case(U, "generate --n-obs 1000 at 8192 px", [*G, "--n-obs", "1000", "--param", "image_size=[8192,8192]",
                                             "-o", "x.zarr"], says=("GiB",), process=True, timeout=60)
case(U, "generate -n 10**18", ["generate", "-n", str(10**18), "-o", "x.zarr"], says=("frames",),
     process=True, timeout=60)
case(U, "generate -n 10**9 starts writing at once", ["generate", "-n", str(10**9), "-o", "x.zarr",
                                                     "--workers", "1"],
     expect=143, process=True, stop=(signal.SIGTERM, "x.zarr.partial/d1/c", 1.0), check=started_at_once,
     timeout=90)

# Internal errors (exit 3) that are really bad input.
case(I, "generate to a URL without its package", [*G, "-o", "gcs://bucket/x.zarr"], says=("gcs://bucket/x.zarr",))
case(I, "generate to an unknown URL scheme", [*G, "-o", "nope://bucket/x.zarr"], says=("nope://",))
case(I, "generate --format hdf5 to a URL", [*G, "--format", "hdf5", "-o", "file:///tmp/x.h5"], says=("URL",))
case(I, "show -o without a suffix", [*SHOW, "-o", "sheet"], STORE_NEEDS, says=("sheet", "suffix"))
case(I, "show -o with an unknown suffix", [*SHOW, "-o", "sheet.xyz"], STORE_NEEDS, says=("sheet.xyz",))
case(I, "score --plot with an unknown suffix", [*SCORE, "--plot", "e.xyz"], STORE_NEEDS, says=("e.xyz",))
for kind, commands in {
    "frame_index past the frames": ("baseline", "convert", "info", "show"),
    "no examples": ("info", "baseline", "score"),
    "z not finite": ("baseline",),
    "largest_area negative": ("baseline",),
    "an example of one frame": ("baseline", "show"),
    "id not UTF-8": ("show", "score"),
}.items():
    for command in commands:
        args = {"baseline": [*VOSDE, "-o", "v.csv"], "convert": ["convert", "tiny.zarr", "t.h5"],
                "info": ["info", "tiny.zarr"], "show": [*SHOW, "-o", "s.png"], "score": SCORE}[command]
        case(I, f"{command} on a store with {kind}", args, STORE_NEEDS, setup=damaged(kind),
             says=("tiny.zarr",))
case(I, "generate --param n_obs=2.5", [*G, "--param", "n_obs=2.5", "-o", "x.zarr"], says=("n_obs must be",))
case(I, "generate --param sizes=7", [*G, "--param", "sizes=7", "-o", "x.zarr"], says=("sizes must be",))
case(I, "generate --param image_size=[0,5]", [*G, "--param", "image_size=[0,5]", "-o", "x.zarr"],
     says=("image_size must be",))
case(I, "generate --param n_points=[true]", [*G, "--param", "n_points=[true]", "-o", "x.zarr"],
     says=("n_points must be",))
case(I, "import recording: a frame that is a folder", REC + ["-o", "out.zarr"], ("rec", "positions.csv"),
     setup=lambda cwd: (cwd / "rec" / "f2.png").unlink() or (cwd / "rec" / "f2.png").mkdir(),
     says=("f2.png",))
case(I, "score: predictions file is a folder", ["score", "photos", "--data", "tiny.zarr"],
     ("tiny.zarr", "photos"), says=("photos",))

# Answers that mislead: validate is the whole of FORMAT.md; messages name the culprit; files are
# written under the names reported.
for kind in ("id without its split", "depth infinite", "no examples", "d1 is not the first frame's depth",
             "duplicate ids", "frame_index past the frames", "largest_area negative"):
    case(M, f"validate finds: {kind}", ["validate", "tiny.zarr"], ("tiny.zarr",), setup=damaged(kind),
         expect=1, check=holds(lambda cwd, r: "INVALID" in r.out, "validate said valid"))
for kind in ("digest wrong", "z not increasing", "d1 is not the first frame's depth"):
    case(M, f"export: a store with {kind} is not published", [*EXPORT, "hub"], ("tiny.zarr",),
         setup=damaged(kind), says=("tiny.zarr", "content digest"))
case(M, "recording: one frame under two spellings", REC + ["-o", "out.zarr"], ("rec", "positions.csv"),
     setup=lambda cwd: (cwd / "positions.csv").write_text(
         (cwd / "positions.csv").read_text() + "./f1.png,0.9,1.0\n"), says=("same file",))
case(M, "recording: RGBA masks drawn in alpha only", REC + ["-o", "out.zarr"], ("rec", "positions.csv"),
     setup=rgba(alpha_only=True), expect=0, outputs=("out.zarr",), check=imported_mask_not_empty)
case(M, "recording: RGBA colour and alpha disagree", REC + ["-o", "out.zarr"], ("rec", "positions.csv"),
     setup=rgba(alpha_only=False), says=("alpha",))
case(M, "an .h5 that is not HDF5", ["info", "x.h5"], setup=write("x.h5", "split,example_id,d1\n"),
     says=("x.h5", "HDF5"), check=holds(lambda cwd, r: "Zarr" not in r.err, "called a Zarr store"))
case(M, "a duplicated id in the truth names the store", SCORE, STORE_NEEDS, setup=damaged("duplicate ids"),
     says=("tiny.zarr", "appears 2 times"))
case(M, "non-finite z names the store, not the CSV", [*VOSDE, "-o", "v.csv"], STORE_NEEDS,
     setup=damaged("z not finite"), says=("tiny.zarr", "z is not finite"))
case(M, "predictions starting with a blank line", ["score", "q.csv", "--data", "tiny.zarr"], STORE_NEEDS,
     setup=lambda cwd: (cwd / "q.csv").write_text("\n" + (cwd / "p.csv").read_text()),
     says=("line 1 is blank",))
case(M, "--plot without a suffix is not written elsewhere", [*SCORE, "--plot", "errs"], STORE_NEEDS,
     says=("errs", "suffix"))
case(M, "--format zarr -o x.h5", [*G, *TINY, "--format", "zarr", "-o", "x.h5"], says=("x.h5", "HDF5"))
case(M, "--format hdf5 -o x.zarr", [*G, *TINY, "--format", "hdf5", "-o", "x.zarr"], says=("x.zarr",))
case(M, "convert --format zarr to x.h5", ["convert", "tiny.zarr", "x.h5", "--format", "zarr"], ("tiny.zarr",),
     says=("x.h5",))
case(M, "the same store twice to --data", [*SCORE, "--data", "tiny.zarr"], STORE_NEEDS, expect=0)
case(M, "a folder and its store to --data", ["score", "p.csv", "--data", "d", "--data", "d/tiny.zarr"],
     ("p.csv",), setup=lambda cwd: _copy(FIXTURES / "tiny.zarr", cwd / "d" / "tiny.zarr"), expect=0)
case(M, "baseline: the same store twice is one",
     ["baseline", "vosde", "tiny.zarr", "./tiny.zarr", "--n-obs", "3", "-o", "v.csv"], ("tiny.zarr",),
     expect=0, outputs=("v.csv",),
     check=holds(lambda cwd, r: (cwd / "v.csv").read_text().count("\n") == 5, "duplicated rows"))
case(M, "an empty folder is not 'unreadable'", ["info", "empty"], ("empty",), says=("empty", "zarr.json"))
case(M, "a text file is not a store", ["info", "notes.zarr"], setup=write("notes.zarr", "hello"),
     says=("notes.zarr", "not a store"))
case(M, "two different stores of one split", ["score", "p.csv", "--data", "tiny.zarr", "--data", "tiny.h5"],
     ("p.csv", "tiny.zarr", "tiny.h5"), says=("two stores hold split tiny",))
case(M, "--plot and --entry name one file", [*SCORE, "--plot", "a.png", "--entry", "a.png", "--name", "Me"],
     STORE_NEEDS, says=("a.png",))

# Consistency: every error in the house form; signals like Ctrl-C; full-disk messages name the
# path; JSON that every parser reads, and no numpy warnings.
for args, say in [
    (["generate", "-n", "abc"], "-n"), (["generate", "-n", "3", "--seed", "-1"], "--seed"),
    (["generate", "-n", "3", "--workers", "0"], "--workers"), (["generate", "--frobnicate"], "--frobnicate"),
    (["show", "tiny.zarr"], "EXAMPLE_ID"), (["generate", "-n", "3", "--format", "xyz"], "--format"),
    (["leaderboard", "--dir", "thesis.pdf"], "thesis.pdf"),
    (["baseline", "vosde", "--n-obs", "1", "-o", "v.csv"], "--n-obs"),
    (["nosuchcommand"], "nosuchcommand"), (["import", "odms"], "DATA_DIR"),
]:
    case(C, f"usage error: {' '.join(args)}", args, ("thesis.pdf",), says=(say,))
case(C, "SIGTERM during generate (2 workers)", ["generate", "-n", "3000", "-o", "t.zarr", "--workers", "2"],
     expect=143, process=True, stop=(signal.SIGTERM, "t.zarr.partial/masks/c", 0.5))
case(C, "SIGHUP during convert", ["convert", "big.zarr", "t.h5"], expect=129, process=True,
     setup=lambda cwd: make_valid(cwd / "big.zarr", count=1000), stop=(signal.SIGHUP, "t.h5.lock", 0.0))
case(C, "SIGTERM during import", [*REC, "-o", "t.zarr"], setup=lambda cwd: _recording(cwd, n=1000),
     expect=143, process=True, stop=(signal.SIGTERM, "t.zarr.partial/masks", 0.0))
case(C, "SIGTERM during export", ["export", "big.zarr", "-o", "hub", "--examples-per-file", "1"],
     expect=143, process=True, setup=lambda cwd: make_valid(cwd / "big.zarr", count=1000),
     stop=(signal.SIGTERM, "hub.partial/data/tiny", 0.0))  # a file per example: seconds of writing left
case(C, "score --json with absurd predictions", [*SCORE[:1], "q.csv", *SCORE[2:], "--json"], STORE_NEEDS,
     setup=lambda cwd: (cwd / "q.csv").write_text(
         "\n".join([HEADER, *(f"tiny,tiny/{i:06d},1e308" for i in range(4))]) + "\n"),
     expect=0, check=strict_json)
case(C, "score with absurd predictions, as a table", [*SCORE[:1], "q.csv", *SCORE[2:]], STORE_NEEDS,
     setup=lambda cwd: (cwd / "q.csv").write_text(
         "\n".join([HEADER, *(f"tiny,tiny/{i:06d},-1.7e308" for i in range(4))]) + "\n"), expect=0)
case(C, "info --json is strict JSON", ["info", "--json", "tiny.zarr"], ("tiny.zarr",), expect=0,
     check=strict_json)
case(C, "validate --json is strict JSON", ["validate", "--json", "tiny.zarr"], ("tiny.zarr",),
     setup=damaged("depth infinite"), expect=1, check=strict_json)
case(C, "a full disk names the path (generate)", [*G, *TINY, "-o", "disk/deep/out.h5"],
     says=("disk/deep/out.h5",), process=True, disk_kib=8)

FIXTURES = Path()  # set by `prepare`


def prepare(root: Path) -> Path:
    global FIXTURES
    FIXTURES = make_fixtures(root)
    return FIXTURES


def main() -> None:
    ap = argparse.ArgumentParser(description="Count the hostile catalogue's kept and broken promises.")
    ap.add_argument("--code", type=Path, help="the checkout whose odms_data to run (default: this one)")
    ap.add_argument("--only", help="run the cases whose name holds this")
    ap.add_argument("-v", action="store_true", help="print every broken case")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        fixtures = prepare(Path(tmp) / "fixtures")
        kept: Counter[str] = Counter()
        total: Counter[str] = Counter()
        for c in CASES:
            if args.only and args.only not in c.name:
                continue
            broken = run_case(c, fixtures, Path(tmp) / "work", code=args.code, inprocess=False)
            total[c.cls] += 1
            kept[c.cls] += not broken
            if broken and args.v:
                print(f"BROKEN [{c.cls}] {c.name}: {'; '.join(broken)[:400]}", flush=True)
    print(f"\nsmall disk: {disk_method()}")
    print(f"{'class':20s} {'cases':>5s} {'kept':>5s} {'broken':>6s}")
    for cls in CLASSES:
        print(f"{cls:20s} {total[cls]:5d} {kept[cls]:5d} {total[cls] - kept[cls]:6d}")
    print(f"{'all':20s} {sum(total.values()):5d} {sum(kept.values()):5d} "
          f"{sum(total.values()) - sum(kept.values()):6d}")


if __name__ == "__main__":
    main()
