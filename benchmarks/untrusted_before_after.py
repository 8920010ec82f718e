"""How many hostile cases the code before issue 27 kept, by class, against the code after it: the
"before and after" table of #27's closing note.

Run by hand, with an old checkout installed in its own venv:

    git archive BEFORE | tar -x -C /tmp/old  # BEFORE: main just before #27 was merged
    python3 -m venv /tmp/old/.venv && /tmp/old/.venv/bin/pip install -e /tmp/old
    python benchmarks/untrusted_before_after.py --before /tmp/old/.venv/bin/odms-data \\
        --after .venv/bin/odms-data

The cases come from the test modules' own tables (tests/test_untrusted_writes.py's WRITERS,
tests/broken_stores.py's HOSTILE with test_untrusted_reads.py's commands, test_untrusted_imports.py's
HOSTILE and HOSTILE_RELEASES, tests/cli/hostile.py's CASES). Each runs its command line against the
given `odms-data` executable in its own process, capped with RLIMIT_AS, and is judged by the tests'
own helpers: one `odms-data: error:` line naming the culprit, exit 2, nothing outside the output
touched. The fixtures are made by this checkout (the store format did not change in between).

Memory: a cap alone cannot tell a bound from an allocation that failed under it (the old code
reported a refused 4 GiB allocation as one line, "unreadable ()"). So every command runs under
strace, counting the mmap/mremap calls that fail, and under GNU time, taking its peak resident
memory; a case is kept only if no allocation was refused and the peak stayed under RSS_BOUND
(what a decode past the bound would touch). The caps leave a valid input room (the controls, run
first on each side, show that valid inputs get no allocation refused and stay under the bound).
Commands stopped by a signal run untraced (strace holds fatal signals back). Needs strace and
/usr/bin/time.

A case whose options the executable's `--help` does not list, or that cannot be run through the
command line, is "not applicable" and listed. Written to benchmarks/results/untrusted_before_after.json.
"""

from __future__ import annotations

import argparse
import os
import re
import resource
import shlex
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time
from collections import Counter
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from functools import cache
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path[:0] = [str(ROOT / "benchmarks"), str(ROOT / "tests"), str(ROOT / "tests" / "cli")]
import _results  # noqa: E402
import hostile as H  # noqa: E402
import test_untrusted_imports as I  # noqa: E402, E741, N812
import test_untrusted_reads as R  # noqa: E402, N812
import test_untrusted_writes as W  # noqa: E402, N812
from broken_stores import HOSTILE, broken_stores, make_valid  # noqa: E402

GIB, MIB = 2**30, 2**20
THREADS = {"OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1"}  # buffers made lazily, as the tests
# Address-space caps: a valid run's peak address space (up to 1.9 GiB for baseline and export, 1.8
# for an import, 2.8 for predict) plus room; the bombs decode to 4 GiB, the declared shapes to more.
STORE_AS = 3 * GIB
IMPORT_AS = 5 * GIB // 2
TORCH_AS = 4 * GIB
# Peak resident memory allowed under each cap: a valid run needs under half of it; a 30000x30000
# mask decodes to 858 MiB, a bomb to 4 GiB.
RSS_BOUND = {STORE_AS: 768 * MIB, IMPORT_AS: 768 * MIB, TORCH_AS: 1536 * MIB}
TRACE = ["strace", "-f", "-qq", "-c", "--seccomp-bpf", "-e", "trace=mmap,mremap", "-o"]


@dataclass
class Ran:
    returncode: int
    stdout: str
    stderr: str
    refused_allocations: int = 0  # mmap/mremap calls that failed (the cap refused them)
    peak_rss: int = 0  # bytes


MEMORY = threading.local()  # .broken: the memory promises broken in the case this thread runs


def refused_allocations(summary: Path) -> int:
    """The failed mmap/mremap calls in strace's -c summary (its errors column)."""
    if not summary.is_file():
        return 0
    fields = [line.split() for line in summary.read_text().splitlines()]
    return sum(int(f[4]) for f in fields if len(f) == 6 and f[5] in ("mmap", "mremap"))


def peak_rss(report: Path) -> int:
    """GNU time's %M (KiB) of the traced command, in bytes."""
    lines = report.read_text().split() if report.is_file() else []
    return int(lines[-1]) * 1024 if lines and lines[-1].isdigit() else 0


def memory_broken(r: Ran, cap: int, bound: int | None) -> list[str]:
    """The memory promise: no allocation refused by the cap, peak resident memory under `bound`."""
    n = r.refused_allocations
    broken = [f"the {cap / GIB:g} GiB cap refused {n} allocation(s) (not bounded by the code)"] if n else []
    if bound is not None and r.peak_rss > bound:
        broken.append(f"peak resident memory {r.peak_rss / MIB:.0f} MiB, over {bound / MIB:.0f} MiB")
    return broken


@dataclass
class Case:
    cls: str
    name: str
    run: Callable[[str, Path], list[str]]  # (executable, a fresh folder) -> the broken promises
    options: tuple[list[str], ...] = ()  # the command lines, for the not-applicable check
    traced: bool = True  # the catalogue's processes run traced (a case stopped by a signal: not)


def odms(exe: str, args: list[str], cwd: Path, limit: int = STORE_AS, env: dict[str, str] | None = None,
         stop_when: Path | None = None) -> Ran:
    """`exe args` in cwd under RLIMIT_AS `limit`, traced (module docstring), its memory promise noted
    for the case this thread runs; SIGTERM once `stop_when` exists (untraced)."""
    def capped() -> None:
        resource.setrlimit(resource.RLIMIT_AS, (limit, limit))

    with tempfile.TemporaryDirectory() as logs:
        summary, report = Path(logs) / "strace", Path(logs) / "time"
        traced = ["/usr/bin/time", "-q", "-f", "%M", "-o", str(report), *TRACE, str(summary)]
        p = subprocess.Popen([*(traced if stop_when is None else []), exe, *args], cwd=cwd,
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, errors="replace",
                             preexec_fn=capped, process_group=0, env={**os.environ, **THREADS, **(env or {})})
        if stop_when is not None:
            deadline = time.monotonic() + 120
            while not stop_when.exists() and p.poll() is None and time.monotonic() < deadline:
                time.sleep(0.05)
            p.send_signal(signal.SIGTERM)
        try:
            out, err = p.communicate(timeout=600)
        except subprocess.TimeoutExpired:
            os.killpg(p.pid, signal.SIGKILL)
            out, err = p.communicate()
            err += "\n(killed after 600 s)"
        r = Ran(p.returncode, out, err, refused_allocations(summary), peak_rss(report))
    if getattr(MEMORY, "broken", None) is not None:
        MEMORY.broken += memory_broken(r, limit, RSS_BOUND.get(limit))
    return r


def held(check: Callable[[], object], what: str) -> list[str]:
    """[] when the test helper's assertions hold, else what broke."""
    try:
        if check() is False:
            return [what]
    except AssertionError as e:
        return [f"{what}: {str(e)[:300]}"]
    except Exception as e:  # noqa: BLE001 - a helper reading a damaged output
        return [f"{what}: {type(e).__name__}: {str(e)[:200]}"]
    return []


def refused(r: Ran, *names: str) -> list[str]:
    return held(lambda: W._refused(r, *names), "not refused in one line naming " + ", ".join(names))


@cache
def help_text(exe: str, command: tuple[str, ...]) -> str:
    return odms(exe, [*command, "--help"], Path.cwd()).stdout


def not_applicable(before: str, after: str, case: Case) -> str:
    """The first option of the case's command lines that the code after #27 lists in its command's
    --help and the code before does not, or ''. (Options neither knows are the case's own point.)"""
    for args in case.options:
        words = [a for a in args[:2] if not a.startswith("-") and "." not in a and "/" not in a]
        command = tuple(words if words[:1] == ["import"] else words[:1])
        for a in args:
            option = re.sub("=.*", "", a)
            new, old = help_text(after, command), help_text(before, command)
            if a.startswith("--") and option in new and option not in old:
                return f"{' '.join(command)} has no {option}"
    return ""


# --- writes: tests/test_untrusted_writes.py's writers with hostile siblings, through the CLI ------

STORE = "s.zarr"  # a valid store of split tiny (make_valid), what baseline and show read


def _generate(out: str) -> list[str]:
    return ["generate", "-n", "2", "--workers", "1", *H.TINY, "-o", out]


CLI_WRITERS: dict[str, Callable[[str], list[str]]] = {  # W.WRITERS' outputs, each by its command
    "v.csv": lambda out: ["baseline", "vosde", STORE, "-o", out],
    "sheet.png": lambda out: ["show", STORE, "tiny/000001", "-o", out],
    "g.zarr": _generate,
    "g.h5": _generate,
}
NOT_CLI = {"entry.json": "score --entry writes only for an official split's content (the release)"}
assert set(CLI_WRITERS) | set(NOT_CLI) == set(W.WRITERS)


def _write(exe: str, cwd: Path, name: str, overwrite: bool, limit: int = STORE_AS) -> Ran:
    return odms(exe, [*CLI_WRITERS[name](name), *(["--overwrite"] if overwrite else [])], cwd, limit)


def _written(cwd: Path, name: str) -> list[str]:
    return held(lambda: W._written(cwd / name), f"{name} not written whole")


def _link_case(name: str, suffix: str, link: str) -> Callable[[str, Path], list[str]]:
    def run(exe: str, cwd: Path) -> list[str]:
        shutil.copytree(FIXTURES / STORE, cwd / STORE)
        thesis, photos = W._victim(cwd)
        broken = []
        if suffix == ".replaced":  # used only when replacing
            first = _write(exe, cwd, name, False)
            if first.returncode:
                return [f"first write failed: {first.stderr.strip()[-200:]}"]
        sib = W.sibling(cwd / name, suffix)
        to = {"to a file": thesis, "to a folder": photos, "dangling": cwd / "elsewhere" / "new"}[link]
        os.symlink(to, sib)
        r = _write(exe, cwd, name, suffix == ".replaced")
        if suffix == ".replaced" and name not in W.FOLDER_OUTPUTS:
            broken += [f"exit {r.returncode}: {r.stderr[-200:]}"] if r.returncode else _written(cwd, name)
        else:
            broken += refused(r, sib.name)
        if not os.path.islink(sib):
            broken.append(f"{sib.name} deleted")
        return broken + held(lambda: W._untouched(thesis, photos), "the user's files touched")
    return run


def _foreign_folder_case(name: str, suffix: str) -> Callable[[str, Path], list[str]]:
    def run(exe: str, cwd: Path) -> list[str]:
        shutil.copytree(FIXTURES / STORE, cwd / STORE)
        if suffix == ".replaced" and _write(exe, cwd, name, False).returncode:
            return ["first write failed"]
        foreign = W.sibling(cwd / name, suffix)
        foreign.mkdir()
        (foreign / "holiday.jpg").write_bytes(b"sea")
        r = _write(exe, cwd, name, suffix == ".replaced")
        if suffix == ".replaced" and name not in W.FOLDER_OUTPUTS:
            broken = [f"exit {r.returncode}"] if r.returncode else _written(cwd, name)
        else:
            broken = refused(r, foreign.name)
        kept = foreign.is_dir() and [p.name for p in foreign.iterdir()] == ["holiday.jpg"]
        return broken + ([] if kept else [f"{foreign.name} not kept"])
    return run


def _foreign_lock_case(name: str, hard_link: bool) -> Callable[[str, Path], list[str]]:
    def run(exe: str, cwd: Path) -> list[str]:
        shutil.copytree(FIXTURES / STORE, cwd / STORE)
        lock = W.sibling(cwd / name, ".lock")
        if hard_link:  # a hard link to the user's file: never truncated
            os.link(W._victim(cwd)[0], lock)
            content = b"%PDF years of work"
        else:
            content = b"my notes, not a process id"
            lock.write_bytes(content)
        r = _write(exe, cwd, name, False)
        broken = refused(r, lock.name)
        if not lock.is_file() or lock.read_bytes() != content:
            broken.append(f"{lock.name} changed")
        return broken + ([f"{name} written"] if (cwd / name).exists() else [])
    return run


def _stale_case(name: str) -> Callable[[str, Path], list[str]]:
    def run(exe: str, cwd: Path) -> list[str]:
        shutil.copytree(FIXTURES / STORE, cwd / STORE)
        W.sibling(cwd / name, ".lock").write_text("999999")
        partial = W.sibling(cwd / name, ".partial")
        partial.mkdir()
        (partial / W.MARKER).write_text("odms-data 999999 x\n")
        (partial / "half").write_bytes(b"half")
        broken = []
        for overwrite in (False, True):
            r = _write(exe, cwd, name, overwrite)
            left = sorted(p.name for p in cwd.iterdir() if p.name != STORE)
            if r.returncode or left != [name]:
                broken.append(f"exit {r.returncode}, left {left}: {r.stderr.strip()[-200:]}")
                break
            broken += _written(cwd, name)
            if not overwrite:
                partial.mkdir()  # killed between mkdir and the marker: empty
        return broken
    return run


def _name_max_case(name: str) -> Callable[[str, Path], list[str]]:
    def run(exe: str, cwd: Path) -> list[str]:
        shutil.copytree(FIXTURES / STORE, cwd / STORE)
        ext = name[name.index("."):]
        n = 252 - len(ext)
        long = "é" * (n // 2) + "x" * (n % 2) + ext
        broken = []
        for overwrite in (False, True):
            r = odms(exe, [*CLI_WRITERS[name](long), *(["--overwrite"] if overwrite else [])], cwd)
            if r.returncode:
                return [f"exit {r.returncode}: {r.stderr.strip()[-200:]}"]
        left = sorted(p.name for p in cwd.iterdir() if p.name != STORE)
        broken += [] if left == [long] else [f"left {[x[:20] for x in left]}"]
        return broken + _written(cwd, long)
    return run


TRAIN = ["--val", STORE, "--iterations", "1", "--batch-size", "2", "--workers", "0", "--device", "cpu"]


def _webapp(exe: str, cwd: Path) -> list[str]:
    """--overwrite replaces only a run odms-data wrote, not a web app's folder with a config.json."""
    shutil.copytree(FIXTURES / STORE, cwd / STORE)
    app = cwd / "webapp"
    app.mkdir()
    (app / "config.json").write_text('{"port": 8080, "config": {}}')
    (app / "index.html").write_text("<html>")
    r = odms(exe, ["train", "-o", "webapp", *TRAIN, "--overwrite"], cwd, TORCH_AS)
    kept = sorted(p.name for p in app.iterdir()) == ["config.json", "index.html"]
    return refused(r, "webapp") + ([] if kept else ["the web app's folder changed"])


def _run_in_store(exe: str, cwd: Path) -> list[str]:
    shutil.copytree(FIXTURES / STORE, cwd / STORE)
    r = odms(exe, ["train", "-o", f"{STORE}/run", *TRAIN], cwd, TORCH_AS)
    inside = [p for p in ("run", "run.lock") if (cwd / STORE / p).exists()]
    return refused(r, STORE) + [f"wrote {STORE}/{p}" for p in inside]


def _train_sigterm(exe: str, cwd: Path) -> list[str]:
    """test_train_stopped_by_sigterm_exits_143, through the executable, on the test's store (examples
    of the standard preset's frames, as many as train's default n_obs)."""
    shutil.copytree(FIXTURES / "train.zarr", cwd / "v.zarr")
    r = odms(exe, ["train", "-o", "run", "--val", "v.zarr", "--iterations", "100000", "--batch-size", "2",
                   "--workers", "0", "--device", "cpu"], cwd, TORCH_AS, stop_when=cwd / "run" / "curves.csv")
    last = (r.stderr.strip().splitlines() or [""])[-1]
    broken = [] if r.returncode == 143 else [f"exit {r.returncode}"]
    broken += [] if last.startswith("odms-data: interrupted (SIGTERM)") else [f"last line {last[:120]!r}"]
    return broken + (["left run.lock"] if (cwd / "run.lock").exists() else [])


def write_cases() -> list[Case]:
    cases = []
    for name in CLI_WRITERS:
        for suffix in (".lock", ".partial", ".replaced"):
            for link in ("to a file", "to a folder", "dangling"):
                cases.append(Case("writes: a link at a sibling", f"{name}: {suffix} links {link}",
                                  _link_case(name, suffix, link), (CLI_WRITERS[name](name),)))
        for suffix in (".partial", ".replaced"):
            cases.append(Case("writes: a foreign sibling", f"{name}: a foreign folder at {suffix}",
                              _foreign_folder_case(name, suffix), (CLI_WRITERS[name](name),)))
        for hard in (False, True):
            cases.append(Case("writes: a foreign sibling", f"{name}: a foreign .lock{' (hard link)' * hard}",
                              _foreign_lock_case(name, hard), (CLI_WRITERS[name](name),)))
        cases.append(Case("writes: our own stale siblings", f"{name}: a stale lock and partial",
                          _stale_case(name), (CLI_WRITERS[name](name),)))
        cases.append(Case("writes: a name at NAME_MAX", f"{name}: 252 bytes", _name_max_case(name),
                          (CLI_WRITERS[name](name),)))
    for name, fn in (("--overwrite on a web app's folder", _webapp), ("a run inside a store", _run_in_store),
                     ("SIGTERM exits 143", _train_sigterm)):
        cases.append(Case("writes: run folders", f"train: {name}", fn, (["train", "-o", "x", *TRAIN],)))
    return cases


# --- reads: broken_stores.HOSTILE through test_untrusted_reads.py's commands --------------------

READ_CLASSES = {"bomb": "reads: compressed chunks", "declared": "reads: declared shapes",
                "missing": "reads: absent chunks", "link": "reads: HDF5 links",
                "virtual": "reads: HDF5 links", "nested": "reads: JSON depth"}
LOADERS = "from odms_data.loaders.numpy_loader import store_batches\nfor _ in store_batches({!r}, 2): pass"


def _loaders(exe: str, store: str, cwd: Path) -> Ran:
    """The loaders' walk (test_untrusted_reads' CHILD), an OdmsError as exit 2 in one line."""
    code = ("import sys\nfrom odms_data.errors import OdmsError\ntry:\n    "
            + LOADERS.format(store).replace("\n", "\n    ")
            + "\nexcept OdmsError as e:\n    print(f'odms-data: error: {e}', file=sys.stderr); sys.exit(2)")
    return odms(str(Path(exe).parent / "python"), ["-c", code], cwd)


def _read_case(name: str, command: str) -> Callable[[str, Path], list[str]]:
    def run(exe: str, cwd: Path) -> list[str]:
        root, stores = hostile_stores(exe)
        store = str(stores[name].relative_to(root))
        if command == "validate":
            r = odms(exe, ["validate", store], root)
            ok = r.returncode == 1 and "INVALID" in r.stdout and "Traceback" not in r.stderr
            return [] if ok else [f"validate exit {r.returncode}: {(r.stdout + r.stderr).strip()[-200:]}"]
        if command == "loaders":
            r, output = _loaders(exe, store, root), None
        else:
            args, output = R.store_commands(store, str(cwd / "out"))[command]
            r = odms(exe, args, root)
        if r.returncode == 0 and command in R.UNREAD.get(name.split(" (")[0], ()):
            return []  # the command never reads the damaged array
        result = [r.returncode, r.stdout, r.stderr]
        broken = held(lambda: R.assert_refused(result, f"{name}: {command}", store),
                      "not refused in one line naming the store")
        return broken + ([f"left {output}"] if output and Path(output).exists() else [])
    return run


@cache
def hostile_stores(exe: str) -> tuple[Path, dict[str, Path]]:
    """test_untrusted_reads' fixture, one per executable (a reader could change what it reads)."""
    root = Path(tempfile.mkdtemp(dir=WORK, prefix="stores-"))
    valid = {"zarr": make_valid(root / "v.zarr"), "h5": make_valid(root / "v.h5")}
    rows = "".join(f"tiny,tiny/{i:06d},0.3\n" for i in range(4))
    (root / "p.csv").write_text("split,example_id,d1\n" + rows)
    return root, broken_stores(root, valid, HOSTILE)


def _deep_json(exe: str, cwd: Path, which: str) -> list[str]:
    """test_json_everywhere_is_depth_bounded, one invocation a case, judged by what its lines say."""
    deep = "[" * 100_000 + "]" * 100_000
    (cwd / "board").mkdir()
    (cwd / "board" / "e.json").write_text(deep)
    (cwd / "run").mkdir()
    (cwd / "run" / "config.json").write_text(deep)
    deeper = "nested deeper than 64"
    args, names, limit = {"--param": (["generate", "-n", "2", "--param", f"d_max={deep}", "-o", "g.zarr"],
                                      ("--param", deeper), STORE_AS),
                          "leaderboard": (["leaderboard", "--dir", "board"], ("e.json", deeper), STORE_AS),
                          "run config": (["predict", "run", "--data", ".", "-o", "p.csv", "--device", "cpu"],
                                         ("not a training run",), TORCH_AS)}[which]
    if which == "--param":  # one argument of a command line holds at most 128 KiB (MAX_ARG_STRLEN)
        args[4] = "d_max=" + "[" * 60_000 + "]" * 60_000
    r = odms(exe, args, cwd, limit)
    return refused(r, *names) + (["left g.zarr"] if (cwd / "g.zarr").exists() else [])


RUNS = {  # test_a_run_folder_is_checked_before_anything_is_built: run -> (config change, best.pt,
    # what the test's error line says)
    "huge": ({"n_obs": 1_000_000}, None, "n_obs must be at most 100"),
    "list": ({}, [1, 2, 3], "holds a list, not a dict"),
    "no-model": ({}, "no-model", "'model' is list, not dict"),
}


def _run_folder(exe: str, cwd: Path, name: str) -> list[str]:
    import json

    import torch

    config = {"model": "odn-l", "n_obs": 10, "val": ["v.zarr"], "seed": 123, **RUNS[name][0]}
    (cwd / name).mkdir()
    (cwd / name / "config.json").write_text(json.dumps({"config": config, "odms_data": "0"}))
    shutil.copytree(FIXTURES / STORE, cwd / "v.zarr")
    best = RUNS[name][1]
    if best is not None:
        torch.save(best if best != "no-model" else {"iteration": 3, "model": [torch.zeros(2)]},
                   cwd / name / "best.pt")
    r = odms(exe, ["predict", name, "--data", "v.zarr", "-o", f"{name}.csv", "--device", "cpu"], cwd,
             TORCH_AS)
    return refused(r, RUNS[name][2]) + ([f"left {name}.csv"] if (cwd / f"{name}.csv").exists() else [])


def _predict_missing(exe: str, cwd: Path, workers: int) -> list[str]:
    """test_predict_never_predicts_from_a_missing_chunk: refused naming the store, no predictions."""
    import json

    import torch

    from odms_data.network import odn
    from odms_data.network.variants import variant

    root, stores = hostile_stores(exe)
    store = str(stores["a mask chunk missing (zarr)"].relative_to(root))
    shutil.copytree(root / store, cwd / store)
    (cwd / "run").mkdir()
    config = {"model": "odn-l", "n_obs": 3, "val": ["v.zarr"], "seed": 123}
    (cwd / "run" / "config.json").write_text(json.dumps({"config": config, "odms_data": "0"}))
    model = odn.build(variant("odn-l"), 3, False).state_dict()
    torch.save({"iteration": 1, "model": model}, cwd / "run" / "best.pt")
    r = odms(exe, ["predict", "run", "--data", store, "-o", "p.csv", "--device", "cpu",
                   "--workers", str(workers)], cwd, TORCH_AS)
    return refused(r, store) + (["wrote p.csv"] if (cwd / "p.csv").exists() else [])


def read_cases() -> list[Case]:
    cases = []
    for name in R.NAMES:
        cls = next(c for key, c in READ_CLASSES.items() if key in name)
        for command in ("validate", *R.store_commands("s", "o"), "loaders"):
            args = R.store_commands("s", "o").get(command, ([command],))[0]
            cases.append(Case(cls, f"{name}: {command}", _read_case(name, command), (args,)))
    for which in ("--param", "leaderboard", "run config"):
        cases.append(Case("reads: JSON depth", f"JSON nested 10^5 deep (--param: 6x10^4): {which}",
                          lambda exe, cwd, w=which: _deep_json(exe, cwd, w)))
    for name in RUNS:
        cases.append(Case("reads: run folders", f"predict from a run folder: {name}",
                          lambda exe, cwd, n=name: _run_folder(exe, cwd, n)))
    for workers in (0, 2):
        cases.append(Case("answers never silently wrong", f"predict --workers {workers} from a missing chunk",
                          lambda exe, cwd, w=workers: _predict_missing(exe, cwd, w),
                          (["predict", "--workers", "--device"],)))
    return cases


# --- imports: test_untrusted_imports.py's hostile recordings, releases and the environment ------

CULPRIT = re.compile(r"[\w.-]+\.(?:png|jpg|csv)|--classes")


def _culprit(says: str) -> tuple[str, ...]:
    """What the test's expected line names (a file, an option); () when it names none."""
    found = CULPRIT.search(says)
    return (found.group(0),) if found else ()


def _recording_case(case: str) -> Callable[[str, Path], list[str]]:
    def run(exe: str, cwd: Path) -> list[str]:
        spoil, args, says = I.HOSTILE[case]
        rec = I.recording(cwd)
        spoil(rec, HUGE_PNG)
        before = I.snapshot(cwd)
        r = odms(exe, ["import", "recording", str(rec / "masks"), "--positions", str(rec / "positions.csv"),
                       "-o", "out.zarr", "--workers", "1", *args], cwd, IMPORT_AS)
        broken = refused(r, *_culprit(says))
        return broken + ([] if I.snapshot(cwd) == before else ["the folder changed"])
    return run


def _release_case(case: str) -> Callable[[str, Path], list[str]]:
    def run(exe: str, cwd: Path) -> list[str]:
        spoil, says = I.HOSTILE_RELEASES[case]
        spoil(I.release(cwd))
        before = I.snapshot(cwd)
        r = odms(exe, ["import", "odms", str(cwd / "data"), "-o", "stores", "--split", "normal-val",
                       "--workers", "1"], cwd, IMPORT_AS)
        return refused(r, *_culprit(says)) + ([] if I.snapshot(cwd) == before else ["the folder changed"])
    return run


def _synthia_label(exe: str, cwd: Path) -> list[str]:
    """test_a_synthia_label_image_declaring_too_much_is_refused's sequence."""
    seq = I.synthia_with_huge_labels(cwd)
    before = I.snapshot(cwd)
    r = odms(exe, ["import", "synthia", str(seq), "-o", "s.zarr", "--workers", "1"], cwd, IMPORT_AS)
    return refused(r, "000000.png") + ([] if I.snapshot(cwd) == before else ["the folder changed"])


def _escapes(exe: str, cwd: Path) -> list[str]:
    rec = I.recording(cwd)
    evil = cwd / "rec" / "cup\x1b]0;owned\x07\x1b[2J"
    (rec / "masks").rename(evil)
    r = odms(exe, ["import", "recording", str(evil), "--positions", str(rec / "positions.csv"),
                   "-o", "cup.zarr", "--workers", "1"], cwd, IMPORT_AS)
    if r.returncode:
        return [f"import exit {r.returncode}"]
    info = odms(exe, ["info", "cup.zarr"], cwd, IMPORT_AS)
    inert = info.returncode == 0 and "\x1b" not in info.stdout and "\x07" not in info.stdout
    return [] if inert else [f"info exit {info.returncode}, escapes shown raw"]


def _latin1(exe: str, cwd: Path) -> list[str]:
    r = odms(exe, ["leaderboard"], cwd, IMPORT_AS, env={"PYTHONIOENCODING": "latin-1"})
    return [] if r.returncode == 0 else [f"exit {r.returncode}: {r.stderr.strip()[-200:]}"]


def _classes(exe: str, cwd: Path, value: str) -> list[str]:
    (cwd / "seq").mkdir()
    args = ["import", "synthia", str(cwd / "seq"), "-o", "s.zarr", "--classes", value]
    r = odms(exe, args, cwd, IMPORT_AS)
    return refused(r, "--classes")


def import_cases() -> list[Case]:
    rec = ["import", "recording", "--positions", "-o", "--workers"]
    cases = [Case("imports: recordings", case, _recording_case(case), ([*rec, *I.HOSTILE[case][1]],))
             for case in I.HOSTILE]
    cases += [Case("imports: the release", case, _release_case(case), (["import", "odms", "--split"],))
              for case in I.HOSTILE_RELEASES]
    cases.append(Case("imports: SYNTHIA", "a label image of 200000x200000", _synthia_label))
    cases.append(Case("imports: text shown", "terminal escapes in a source, shown by info", _escapes))
    cases += [Case("imports: the user's environment", f"--classes {v}",
                   lambda exe, cwd, v=v: _classes(exe, cwd, v), (["import", "synthia", "--classes"],))
              for v in ("70000", "²")]
    cases.append(Case("imports: the user's environment", "leaderboard on a Latin-1 terminal", _latin1))
    return cases


# --- the catalogue: tests/cli/hostile.py's CASES, each in its own process --------------------------

@cache
def code_of(exe: str) -> Path:
    """The folder holding the executable's odms_data package (hostile.py's --code)."""
    where = "import os, odms_data; print(os.path.dirname(os.path.dirname(odms_data.__file__)))"
    return Path(odms(str(Path(exe).parent / "python"), ["-c", where], Path.cwd()).stdout.strip())


CATALOGUE_AS = 6 * GIB  # hostile.py's own cap (run_process); it judges memory itself where it matters
TRACED_PYTHON = """#!/bin/sh
# this interpreter under GNU time and strace, their reports beside the case's folder
d=$(dirname "$(pwd)")
exec /usr/bin/time -q -f %M -o "$d/time" {trace} "$d/strace" {python} "$@"
"""


def _catalogue_case(case: H.Case) -> Callable[[str, Path], list[str]]:
    """hostile.py runs its command with sys.executable, which main() points at TRACED_PYTHON."""
    def run(exe: str, cwd: Path) -> list[str]:
        broken = H.run_case(case, CATALOGUE, cwd, code=code_of(exe), inprocess=False)
        traced = Ran(0, "", "", refused_allocations(cwd / "strace"), peak_rss(cwd / "time"))
        return broken + memory_broken(traced, CATALOGUE_AS, None)
    return run


def catalogue_cases() -> list[Case]:
    return [Case(f"catalogue: {c.cls}", c.name, _catalogue_case(c), (c.args,), traced=c.stop is None)
            for c in H.CASES]


# --- running ----------------------------------------------------------------------------------

FIXTURES = Path()
CATALOGUE = Path()
WORK = Path()
HUGE_PNG = b""
GROUPS = {"writes": write_cases, "reads": read_cases, "imports": import_cases, "catalogue": catalogue_cases}


def run_side(case: Case, exe: str, cwd: Path) -> list[str]:
    cwd.mkdir()
    MEMORY.broken = []
    try:
        broken = case.run(exe, cwd)
        return MEMORY.broken + broken
    except Exception as e:  # noqa: BLE001 - a case's setup meeting the other code's output
        return [f"{type(e).__name__}: {str(e)[:200]}", *MEMORY.broken]
    finally:
        MEMORY.broken = None
        shutil.rmtree(cwd, ignore_errors=True)


def controls(exe: str) -> dict[str, str]:
    """Valid inputs through each kind of command the cases run, under the same caps and judge: each
    should exit 0 with no allocation refused and its peak resident memory under the bound."""
    cwd = Path(tempfile.mkdtemp(dir=WORK, prefix="controls-"))
    shutil.copytree(FIXTURES / STORE, cwd / STORE)
    shutil.copytree(FIXTURES / "train.zarr", cwd / "v.zarr")
    rows = "".join(f"tiny,tiny/{i:06d},0.3\n" for i in range(4))
    (cwd / "p.csv").write_text("split,example_id,d1\n" + rows)
    rec = I.recording(cwd)
    masks, positions = str(rec / "masks"), str(rec / "positions.csv")
    runs = {command: (args, STORE_AS) for command, (args, _) in R.store_commands(STORE, "out").items()}
    runs |= {"validate": (["validate", STORE], STORE_AS), "generate": (_generate("g.zarr"), STORE_AS),
             "import recording": (["import", "recording", masks, "--positions", positions, "-o", "rec.zarr",
                                   "--workers", "1"], IMPORT_AS),
             "leaderboard": (["leaderboard"], IMPORT_AS),
             "train": (["train", "-o", "run", "--val", "v.zarr", "--iterations", "2", "--batch-size", "2",
                        "--workers", "0", "--device", "cpu"], TORCH_AS),
             "predict": (["predict", "run", "--data", "v.zarr", "-o", "run.csv", "--device", "cpu"],
                         TORCH_AS)}
    seen = {name: (odms(exe, args, cwd, cap), cap) for name, (args, cap) in runs.items()}
    seen["loaders"] = _loaders(exe, STORE, cwd), STORE_AS
    shutil.rmtree(cwd, ignore_errors=True)
    said = {}
    for name, (r, cap) in seen.items():
        failed = [r.stderr.strip()[-200:]] if r.returncode else []
        said[name] = "; ".join([f"exit {r.returncode}, peak {r.peak_rss / MIB:.0f} MiB",
                                *memory_broken(r, cap, RSS_BOUND[cap]), *failed])
    return said


def main() -> None:
    global FIXTURES, CATALOGUE, WORK, HUGE_PNG
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--before", required=True, help="the odms-data executable of the code before #27")
    ap.add_argument("--after", required=True, help="the odms-data executable of the code after it")
    ap.add_argument("--groups", default=",".join(GROUPS), help="which groups of cases: " + ", ".join(GROUPS))
    ap.add_argument("--only", default="", help="only the cases whose name holds this")
    ap.add_argument("-v", action="store_true", help="print every broken case")
    _results.add_options(ap)
    args = ap.parse_args()
    sides = {"before": args.before, "after": args.after}
    kept: dict[str, Counter[str]] = {side: Counter() for side in sides}
    applicable: Counter[str] = Counter()
    total: Counter[str] = Counter()
    listed: dict[str, list[str]] = {"not_applicable": [*(f"writes: {k}: {v}" for k, v in NOT_CLI.items())],
                                    "broken_before": [], "broken_after": []}
    with tempfile.TemporaryDirectory() as tmp, ThreadPoolExecutor(2) as pool:
        WORK = Path(tmp)
        FIXTURES = WORK / "fixtures"
        FIXTURES.mkdir()
        make_valid(FIXTURES / STORE)
        W.generate(str(FIXTURES / "train.zarr"), 4, W.PRESETS["standard"], 5, workers=1)
        CATALOGUE = H.prepare(WORK / "catalogue")
        HUGE_PNG = I.png(30000, 30000)
        checked = {side: pool.submit(controls, exe) for side, exe in sides.items()}
        for side, future in checked.items():
            listed[f"controls_{side}"] = [f"{k}: {v}" for k, v in future.result().items()]
            print(f"controls {side}:", *listed[f"controls_{side}"], sep="\n  ", file=sys.stderr, flush=True)
        python = sys.executable
        traced_python = WORK / "traced-python"
        traced_python.write_text(TRACED_PYTHON.format(trace=shlex.join(TRACE), python=shlex.quote(python)))
        traced_python.chmod(0o755)
        groups = args.groups.split(",")
        for done, group in enumerate(groups, 1):
            cases = [c for c in GROUPS[group]() if args.only in c.name]
            for i, case in enumerate(cases):
                total[case.cls] += 1
                why = not_applicable(args.before, args.after, case)
                if why:
                    listed["not_applicable"].append(f"{case.cls}: {case.name}: {why}")
                applicable[case.cls] += not why
                sys.executable = str(traced_python) if case.traced else python  # hostile.py's interpreter
                run = {side: pool.submit(run_side, case, exe, WORK / f"{side}-{group}-{i}")
                       for side, exe in sides.items() if not (why and side == "before")}
                for side, future in run.items():
                    broken = future.result()
                    kept[side][case.cls] += not broken
                    if broken:
                        line = f"{case.cls}: {case.name}: {'; '.join(broken)[:500]}"
                        listed[f"broken_{side}"].append(line)
                        if args.v:
                            print(f"BROKEN {side}: {line}", flush=True)
                print(f"{group} {i + 1}/{len(cases)} {case.name}", file=sys.stderr, flush=True)
            save(args, total, applicable, kept, listed, groups[:done])
        sys.executable = python


def save(args: argparse.Namespace, total: Counter[str], applicable: Counter[str],
         kept: dict[str, Counter[str]], listed: dict[str, list[str]], groups: list[str]) -> None:
    """The table so far (after each group, so that a stopped run keeps what it measured)."""
    rows = [{"class": cls, "cases": total[cls], "applicable_before": applicable[cls],
             "kept_before": kept["before"][cls], "kept_after": kept["after"][cls]} for cls in total]
    rows.append({"class": "all", "cases": sum(total.values()), "applicable_before": sum(applicable.values()),
                 "kept_before": sum(kept["before"].values()), "kept_after": sum(kept["after"].values())})
    for row in rows:
        print(f"{row['class']:40s} {row['cases']:5d} {row['applicable_before']:5d} {row['kept_before']:5d} "
              f"{row['kept_after']:5d}")
    _results.save(args, "Hostile cases kept, by class, before and after issue 27",
                  {"what": "cases kept by the code before #27", "value": rows[-1]["kept_before"],
                   "unit": "cases"},
                  rows, {"before": args.before, "after": args.after, "groups_run": groups, **listed})


if __name__ == "__main__":
    main()
