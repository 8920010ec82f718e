"""The hostile matrix (issue 37 §2): every parameter of every command, found by walking click's
command tree, classified by kind and given every hostile value of its kind; each run judged by
one rule. A new command or option is covered the day it is added, and one the matrix cannot
classify fails tests/cli/test_matrix.py.

A case is one command's valid base invocation (`BASES`) with one parameter set to one hostile
value (`values_for`). The rule (`judge`, on top of hostile.promises_broken): exit 2 with one line
`odms-data: error: ...` (or 0 where the value is one the command may honour, e.g. an extreme count
or an escaped name; 1 is validate's verdict); no traceback or warning on stderr; nothing changed
outside the outputs (a victim folder `outside/` beside the working folder included); no marker
file (code from the working folder, a pickle or a shell ran); no raw control character printed;
peak memory under `MEMORY_MIB`; done within the timeout, or still at work showing progress.

Each case runs in its own process, forked from a server (`Server`, `python matrix.py --serve`)
that has imported the command line and its heavy dependencies once, so that a case costs
milliseconds, not a start-up; its stdout and stderr are only what that command printed.

    python tests/cli/matrix.py --list        # the matrix: commands x parameters x values
"""

from __future__ import annotations

import hashlib
import json
import os
import pickle
import resource
import select
import shutil
import signal
import subprocess
import sys
import tempfile
import time
import zipfile
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field, replace
from functools import cache
from pathlib import Path

import click

HERE = Path(__file__).resolve().parent
sys.path[:0] = [str(HERE), str(HERE.parent)]

from broken_stores import copy_store  # noqa: E402
from hostile import Case, Result, promises_broken, snapshot  # noqa: E402

MEMORY_MIB = 1024  # peak resident memory a hostile value may cost a command (its own process)
TIMEOUT = 20.0  # seconds before a run is stopped; a run still showing progress then is kept
MARKERS = {  # files in the working folder that leave a marker when they run
    "multiprocessing.py": "import pathlib; pathlib.Path('marker-multiprocessing').touch()\n",
    "sitecustomize.py": "import pathlib; pathlib.Path('marker-sitecustomize').touch()\n",
}


# --- the command tree -------------------------------------------------------------------------

@dataclass(frozen=True)
class Slot:
    """One parameter of one command."""

    command: tuple[str, ...]  # ("import", "odmd")
    param: click.Parameter = field(compare=False)

    @property
    def key(self) -> str:
        return f"{' '.join(self.command)} {self.param.name}"

    @property
    def flag(self) -> str:
        """How the parameter is given: its longest option name, or '' for an argument."""
        return max(self.param.opts, key=len) if isinstance(self.param, click.Option) else ""


def commands() -> dict[tuple[str, ...], click.Command]:
    """Every command of `odms-data` that runs, by its path: the leaves, and each group that runs
    without a subcommand (`leaderboard`)."""
    from odms_data.cli import main

    out: dict[tuple[str, ...], click.Command] = {}

    def walk(cmd: click.Command, path: tuple[str, ...], ctx: click.Context) -> None:
        if isinstance(cmd, click.Group):
            if cmd.invoke_without_command and path:
                out[path] = cmd
            for name in cmd.list_commands(ctx):
                sub = cmd.get_command(ctx, name)
                assert sub is not None, name
                walk(sub, (*path, name), click.Context(sub, parent=ctx, info_name=name))
        else:
            out[path] = cmd

    walk(main, (), click.Context(main, info_name="odms-data"))
    return out


def slots() -> list[Slot]:
    """Every parameter of every command (not --help)."""
    return [Slot(path, p) for path, cmd in commands().items() for p in cmd.params
            if not (isinstance(p, click.Option) and p.name == "help")]


# --- kinds ------------------------------------------------------------------------------------
# What a path or a text names cannot be read off its click type: each is listed here by
# "command parameter". Choices, flags and numbers are classified by their type.
OUT = "output"
ROLES: dict[str, tuple[str, str]] = {  # key -> (kind, suffix of its base value for outputs)
    "baseline box-ls stores": ("store", ""), "baseline box-ls data": ("store", ""),
    "baseline box-ls output": (OUT, ".csv"),
    "baseline vosde stores": ("store", ""), "baseline vosde data": ("store", ""),
    "baseline vosde output": (OUT, ".csv"),
    "convert src": ("store", ""), "convert dst": (OUT, ".h5"),
    "estimate store": ("store", ""), "estimate checkpoint": ("run", ""), "estimate output": (OUT, ""),
    "estimate plot": (OUT, ".png"), "estimate device": ("text", ""),
    "export stores": ("store", ""), "export output": (OUT, ""), "export name": ("text", ""),
    "export licence": ("text", ""),
    "compare a": ("predictions", ""), "compare b": ("predictions", ""), "compare data": ("store", ""),
    "generate split_name": ("split", ""), "generate params": ("text", ""), "generate configs": ("config", ""),
    "generate store_split": ("text", ""),
    "generate output": (OUT, ".zarr"), "generate scheduler": ("url", ""),
    "import odmd data_dir": ("pickles", ""), "import odmd out_dir": (OUT, ""),
    "import odms data_dir": ("release", ""), "import odms out_dir": (OUT, ""),
    "import recording mask_dir": ("recording", ""), "import recording positions": ("positions", ""),
    "import recording poses": ("poses", ""), "import recording output": (OUT, ".zarr"),
    "import recording windows": ("text", ""),
    "import recording name": ("text", ""),
    "import detections detections": ("detections", ""), "import detections poses": ("poses", ""),
    "import detections images": ("detections", ""), "import detections image_size": ("text", ""),
    "import detections output": (OUT, ".zarr"), "import detections windows": ("text", ""),
    "import detections name": ("text", ""),
    "import synthia seq_dirs": ("synthia", ""), "import synthia output": (OUT, ".zarr"),
    "import synthia classes": ("text", ""), "import synthia frames": ("text", ""),
    "import synthia name": ("text", ""),
    "info stores": ("store", ""), "validate stores": ("store", ""),
    "leaderboard folders": ("entries", ""), "leaderboard site": (OUT, ""),
    "leaderboard verify folders": ("entries", ""), "leaderboard verify data": ("store", ""),
    "leaderboard data": ("store", ""),
    "predict run": ("run", ""), "predict data": ("store", ""), "predict output": (OUT, ".csv"),
    "predict checkpoint": ("checkpoint", ""), "predict device": ("text", ""),
    "score predictions": ("predictions", ""), "score data": ("store", ""), "score plot": (OUT, ".png"),
    "score entry": (OUT, ".json"), "score name": ("text", ""), "score citation": ("text", ""),
    "score link": ("url", ""),
    "show store": ("store", ""), "show example_id": ("text", ""), "show output": (OUT, ".png"),
    "train run": (OUT, ""), "train val": ("store", ""), "train device": ("text", ""),
}


INTO = {"import odmd out_dir", "import odms out_dir"}  # outputs that are folders of outputs


class Unclassified(Exception):
    pass


def kind_of(slot: Slot) -> str:
    """The slot's kind: an input kind of ROLES, 'output', 'url', 'text', 'split' (a named split,
    refused when unknown), 'number', 'choice' or 'flag'; Unclassified when neither its type nor
    ROLES says."""
    p, t = slot.param, slot.param.type
    if isinstance(p, click.Option) and p.is_flag:
        return "flag"
    if isinstance(t, click.Choice):
        return "choice"
    if isinstance(t, click.types.IntParamType | click.types.FloatParamType):
        return "number"
    if isinstance(t, click.Path | click.types.StringParamType) and slot.key in ROLES:
        return ROLES[slot.key][0]
    raise Unclassified(f"{slot.key} ({type(t).__name__}): add it to ROLES in tests/cli/matrix.py")


# --- valid base invocations -------------------------------------------------------------------
# command -> the parameters' values (a list for nargs=-1 and multiple options), fixtures it reads
BASES: dict[str, tuple[dict[str, str | list[str]], tuple[str, ...]]] = {
    "baseline box-ls": ({"stores": ["generated"], "data": ["box.zarr"], "output": "b.csv"}, ("box.zarr",)),
    "baseline vosde": ({"stores": ["tiny"], "data": ["tiny.zarr"], "output": "v.csv", "n_obs": "3"},
                       ("tiny.zarr",)),
    "compare": ({"a": "p.csv", "b": "p.csv", "data": ["tiny.zarr"]}, ("p.csv", "tiny.zarr")),
    "convert": ({"src": "tiny.zarr", "dst": "t.h5"}, ("tiny.zarr",)),
    "estimate": ({"store": "tiny.zarr", "method": "run", "checkpoint": "run", "output": "est", "workers": "0",
                  "device": "cpu"}, ("tiny.zarr", "run")),
    "export": ({"stores": ["tiny.zarr"], "output": "hub"}, ("tiny.zarr",)),
    "generate": ({"count": "3", "workers": "1", "params": ["image_size=[24,36]", "sizes=[12,20]"],
                  "output": "g.zarr"}, ()),
    "import odmd": ({"data_dir": "odmd", "out_dir": "out", "sets": ["odmd-normal-val"]}, ("odmd",)),
    "import odms": ({"data_dir": "release", "out_dir": "out", "splits": ["normal-val"], "workers": "1",
                     "no_verify": "1"},
                    ("release",)),
    "import recording": ({"mask_dir": "rec", "positions": "positions.csv", "output": "r.zarr",
                          "workers": "1"},
                         ("rec", "positions.csv")),
    "import detections": ({"detections": "gt.txt", "poses": "poses.txt", "track": "1", "image_size": "64x48",
                           "output": "d.zarr"}, ("gt.txt", "poses.txt")),
    "import synthia": ({"seq_dirs": ["synthia"], "output": "s.zarr", "workers": "1", "frames": "3",
                        "move": ["1", "60"]},
                       ("synthia",)),
    "info": ({"stores": ["tiny.zarr"]}, ("tiny.zarr",)),
    "validate": ({"stores": ["tiny.zarr"]}, ("tiny.zarr",)),
    "leaderboard": ({}, ()),
    "leaderboard verify": ({"data": ["tiny.zarr"]}, ("tiny.zarr",)),
    "predict": ({"run": "run", "data": ["tiny.zarr"], "output": "pr.csv", "n_obs": "3", "workers": "0",
                 "device": "cpu"}, ("run", "tiny.zarr")),
    "score": ({"predictions": "p.csv", "data": ["tiny.zarr"]}, ("p.csv", "tiny.zarr")),
    "show": ({"store": "tiny.zarr", "example_id": "tiny/000001", "output": "s.png"}, ("tiny.zarr",)),
    "train": ({"run": "run2", "val": ["tiny.zarr"], "iterations": "1", "batch_size": "2", "workers": "1",
               "n_obs": "3", "device": "cpu"}, ("tiny.zarr",)),
}


# --- hostile values ---------------------------------------------------------------------------
Setup = Callable[[Path], None]  # makes what the value names, in the case's working folder


@dataclass(frozen=True)
class Value:
    name: str
    args: tuple[str, ...]  # what is given for the parameter (two items for nargs=2)
    setup: Setup | None = None
    payload: str = ""  # text that must not reach a markdown or HTML output raw
    rebase: tuple[tuple[str, str | None], ...] = ()  # base parameters it needs changed (None: left out)


def _link(name: str, target: str) -> Setup:
    return lambda cwd: os.symlink(target, cwd / name)


def _fifo(name: str) -> Setup:
    return lambda cwd: os.mkfifo(cwd / name)


def _write(rel: str, data: bytes | str) -> Setup:
    def setup(cwd: Path) -> None:
        (cwd / rel).parent.mkdir(parents=True, exist_ok=True)
        (cwd / rel).write_bytes(data if isinstance(data, bytes) else data.encode())
    return setup


def _copy_fixture(src: str, dst: str) -> Setup:
    def setup(cwd: Path) -> None:
        if os.path.lexists(cwd / dst):
            return
        s = FIXTURES.get(src)
        copy_store(s, cwd / dst)
    return setup


def _steps(*fns: Setup) -> Setup:
    def setup(cwd: Path) -> None:
        for fn in fns:
            fn(cwd)
    return setup


def any_input(kind: str) -> list[Value]:
    """What every input path gets, whatever it names."""
    good = {"store": "tiny.zarr", "predictions": "p.csv", "run": "run", "checkpoint": "ck.pt",
            "pickles": "odmd", "release": "release", "recording": "rec", "positions": "positions.csv",
            "poses": "poses.txt", "synthia": "synthia", "entries": "entries", "config": "turn.yaml",
            "detections": "gt.txt"}[kind]
    return [
        Value("missing", ("missing.x",)),
        Value("an empty folder", ("empty",), lambda cwd: (cwd / "empty").mkdir()),
        Value("a folder of photos", ("photos",)),
        Value("a PDF", ("thesis.pdf",)),
        Value("/dev/zero", ("/dev/zero",)),
        Value("a FIFO", ("fifo",), _fifo("fifo")),
        Value("a dangling link", ("dangling",), _link("dangling", "nowhere")),
        Value("a link loop", ("loop",), _link("loop", "loop")),
        Value("a link to /etc/passwd", ("passwd",), _link("passwd", "/etc/passwd")),
        Value("a name with an escape", ("x\x1b[2Jy",), _copy_fixture(good, "x\x1b[2Jy")),
        Value("a name with a newline", ("x\ny",), _copy_fixture(good, "x\ny")),
        Value("a name of 300 bytes", ("n" * 300,)),
        Value("an empty name", ("",)),
        Value("a URL of an unknown scheme", ("nope://bucket/x",)),
        Value("memory://", ("memory://x",)),
        Value("s3://", ("s3://bucket/x",)),
        Value("http://", ("http://127.0.0.1:1/x",)),
        Value("ssh://", ("ssh://host/x",)),
    ]


def store_values() -> list[Value]:
    from broken_stores import DAMAGE, HOSTILE

    out = []
    for table in (DAMAGE, HOSTILE):
        for name, (backends, _) in table.items():
            for backend in backends.split():
                suffix = ".zarr" if backend == "zarr" else ".h5"
                bad = f"bad{suffix}"
                out.append(Value(f"{name} ({backend})", (bad,),
                                 _copy_fixture(f"store:{name}:{backend}", bad)))
    out.append(Value("a folder holding a broken store", ("d",), _steps(
        lambda cwd: (cwd / "d").mkdir(), _copy_fixture("store:digest wrong:zarr", "d/bad.zarr"))))
    return out


PRED = "split,example_id,d1\n"
ROWS = "".join(f"tiny,tiny/{i:06d},0.3\n" for i in range(4))
CSV_VALUES = {  # name -> content of a predictions CSV
    "binary noise": bytes(range(256)) * 4,
    "empty": b"",
    "header only": PRED.encode(),
    "a NUL": (PRED + "tiny,tiny/000000,0.3\x00\n").encode(),
    "d1 NaN": (PRED + ROWS.replace("0.3", "nan")).encode(),
    "d1 infinite": (PRED + ROWS.replace("0.3", "inf")).encode(),
    "d1 1e400": (PRED + ROWS.replace("0.3", "1e400")).encode(),
    "d1 negative": (PRED + ROWS.replace("0.3", "-0.3")).encode(),
    "duplicate rows": (PRED + ROWS + ROWS).encode(),
    "unknown ids": (PRED + ROWS.replace("tiny/", "nope/")).encode(),
    "a quoted newline in an id": (PRED + '"tiny","tiny/\n000000",0.3\n' + ROWS).encode(),
    "an escape in an id": (PRED + ROWS + "tiny,tiny/\x1b[2J,0.3\n").encode(),
    "a line of 2 MB": (PRED + "tiny,tiny/" + "x" * 2_000_000 + ",0.3\n").encode(),
    "UTF-16": (PRED + ROWS).encode("utf-16"),
    "10^5 columns": (PRED.strip() + ",x" * 100_000 + "\n").encode(),
}


def predictions_values() -> list[Value]:
    return [Value(f"a CSV: {n}", ("q.csv",), _write("q.csv", c)) for n, c in CSV_VALUES.items()]


def positions_values() -> list[Value]:
    rows = "".join(f"f{i}.png,{0.2 + 0.02 * i:.3f},{0.3 + 0.02 * i:.3f}\n" for i in range(6))
    head = "frame,z,depth\n"
    contents = {
        "binary noise": bytes(range(256)) * 4, "empty": b"", "header only": head.encode(),
        "z NaN": (head + rows.replace("0.200", "nan")).encode(),
        "depth 1e400": (head + rows.replace("0.300", "1e400")).encode(),
        "a row ../outside": (head + rows + "../outside/thesis.pdf,0.5,0.6\n").encode(),
        "an absolute row": (head + rows + "/etc/passwd,0.5,0.6\n").encode(),
        "a line of 2 MB": (head + "f" * 2_000_000 + ".png,0.5,0.6\n").encode(),
        "10^5 rows of one frame": (head + "f0.png,0.5,0.6\n" * 100_000).encode(),
    }
    return [Value(f"positions: {n}", ("q.csv",), _write("q.csv", c)) for n, c in contents.items()]


def poses_values() -> list[Value]:
    row = "1 0 0 0 0 1 0 0 0 0 1 {z} 0 0 0 1\n"
    rows = "".join(row.format(z=f"{0.2 + 0.02 * i:.3f}") for i in range(6))
    contents = {
        "binary noise": bytes(range(256)) * 4, "empty": b"",
        "a row of 15 numbers": (rows + "1 0 0 0 0 1 0 0 0 0 1 0 0 0 0\n").encode(),
        "z NaN": rows.replace("0.200", "nan").encode(),
        "a matrix of 1e400": rows.replace("0.200", "1e400").encode(),
        "not a rotation": rows.replace("1 0 0 0 0 1", "9 0 0 0 0 1", 1).encode(),
        "a line of 2 MB": (rows + "1 " * 1_000_000 + "\n").encode(),
        "10^5 rows": (row.format(z="0.5") * 100_000).encode(),
        "a .npy declaring 10^12 matrices": b"\x93NUMPY\x01\x00v\x00{'descr': '<f8', 'fortran_order': False, "
                                          b"'shape': (1000000000000, 4, 4), }" + b" " * 51 + b"\n",
    }
    return [Value(f"poses: {n}", ("q.npy" if n.startswith("a .npy") else "q.txt",),
                  _write("q.npy" if n.startswith("a .npy") else "q.txt", c)) for n, c in contents.items()]


def split_values() -> list[Value]:
    """A named split's hostile names: every text, and names close to a real one."""
    return [*TEXTS, Value("an unknown split", ("nope",)), Value("upper case", ("SIM-VAL",)),
            Value("a real name and a path", ("sim-val/../../outside/x",))]


def _pickle_rce(marker: str) -> bytes:
    return f"cos\nsystem\n(S'touch {marker}'\ntR.".encode()


def _memo_bomb() -> bytes:
    row = [0.5] * 1000
    rows = [row] * 1000
    cube = [rows] * 1000  # 10^9 numbers when expanded, a few KB pickled (the memo shares)
    return pickle.dumps({"bb": {"bboxes": cube, "n_positions": 10, "n_ex": 1000, "image_dim": [480, 640]},
                         "bb_3D": {"camera_movement": cube, "n_ex": 1000, "n_positions": 10}}, protocol=3)


def _deep_pickle(depth: int = 1_000_000) -> bytes:
    return b"(" * depth + b"l" * depth + b"."  # lists nested a million deep


def pickles_values() -> list[Value]:
    from odms_data.importers.odmd import ODMD_SETS

    rel = "odmd/" + ODMD_SETS["odmd-normal-val"][0]
    contents = {"code that runs": _pickle_rce("marker-pickle"), "a memo bomb": _memo_bomb(),
                "nested a million deep": _deep_pickle(), "binary noise": bytes(range(256)) * 4,
                "truncated": _memo_bomb()[:100], "a dict key nested deep": _deep_dict_key()}
    return [Value(f"ODMD pickles: {n}", ("odmd",), _steps(_copy_fixture("odmd", "odmd"), _write(rel, c)))
            for n, c in contents.items()]


def _deep_dict_key(depth: int = 1_000_000) -> bytes:
    """{(((...),),): 0}: a tuple nested a million deep as a dict key."""
    return b"\x80\x02}" + b")" + b"\x85" * depth + b"K\x00s."


def _zip_pt(records: dict[str, bytes], big: tuple[str, int] | None = None) -> bytes:
    """A torch-style zip of `records` (stored); `big` = (record, n): n bytes of zeros, deflated
    (a 16 MiB block's deflate repeated, so the bomb costs a second to make)."""
    import struct
    import zlib

    entries = [(name, data, 0, zlib.crc32(data), len(data)) for name, data in records.items()]
    if big:
        zeros, c = bytes(2**24), zlib.compressobj(9, zlib.DEFLATED, -15)
        first = c.compress(zeros) + c.flush(zlib.Z_FULL_FLUSH)
        piece = c.compress(zeros) + c.flush(zlib.Z_FULL_FLUSH)
        n, crc = big[1] // len(zeros), 0
        for _ in range(n):
            crc = zlib.crc32(zeros, crc)
        entries.append((big[0], first + piece * (n - 1) + c.flush(), 8, crc, n * len(zeros)))
    out, central = bytearray(), bytearray()
    for name, data, method, crc, size in entries:
        raw = f"archive/{name}".encode()
        fields = struct.pack("<HHHHHIII", 20, 0, method, 0, 0x21, crc, len(data), size)
        central += b"PK\x01\x02" + struct.pack("<H", 20) + fields + struct.pack(
            "<HHHHHII", len(raw), 0, 0, 0, 0, 0, len(out)) + raw
        out += b"PK\x03\x04" + fields + struct.pack("<HH", len(raw), 0) + raw + data
    end = struct.pack("<HHHHIIH", 0, 0, len(entries), len(entries), len(central), len(out), 0)
    return bytes(out + central + b"PK\x05\x06" + end)


@cache
def _checkpoints() -> dict[str, bytes]:
    """Hostile checkpoint files, by name."""
    import io

    import torch

    buf = io.BytesIO()
    torch.save({"iteration": 1, "model": {"w": torch.zeros(4)}}, buf)
    good = buf.getvalue()
    with zipfile.ZipFile(io.BytesIO(good)) as z:
        records = {n.split("/", 1)[1]: z.read(n) for n in z.namelist()}
    storage = next(n for n in records if n.startswith("data/"))
    sparse = io.BytesIO()
    torch.save({"iteration": 1, "model": {"w": torch.zeros(4, 4).to_sparse()}}, sparse)
    return {
        "code that runs": _zip_pt({**records, "data.pkl": _pickle_rce("marker-checkpoint")}),
        "a plain pickle that runs code": _pickle_rce("marker-checkpoint"),
        "a storage record deflated from 1.5 GiB": _zip_pt({k: v for k, v in records.items() if k != storage},
                                                          (storage, 3 * 2**29)),
        "a sparse tensor": sparse.getvalue(),
        "binary noise": bytes(range(256)) * 4,
        "truncated": good[: len(good) // 2],
        "nested a million deep": _deep_pickle(),
    }


def checkpoint_values() -> list[Value]:
    """--checkpoint: a run's checkpoint by name (the run given), or a weights file (with --model, no
    run)."""
    given = (("not a name", "nope"), ("upper case", "BEST"), ("a prefix", "per"),
             ("an escape", "best\x1b[2J"), ("empty", ""), ("10^6 characters", "a" * 10**6))
    return [*(Value(f"a run's checkpoint: {n}", (v,)) for n, v in given),
            *(replace(v, rebase=REBASE["checkpoint"]) for v in any_input("checkpoint") + checkpoint_files())]


def checkpoint_files() -> list[Value]:
    names = ("code that runs", "a plain pickle that runs code", "a storage record deflated from 1.5 GiB",
             "a sparse tensor", "binary noise", "truncated", "nested a million deep")
    out = [Value(f"a checkpoint: {n}", ("ck.pt",),
                 lambda cwd, n=n: (cwd / "ck.pt").write_bytes(_checkpoints()[n])) for n in names]
    out.append(Value("a checkpoint of 3 GiB (sparse file)", ("ck.pt",), lambda cwd: os.truncate(
        _touch(cwd / "ck.pt"), 3 * 2**30)))
    out.append(Value("a checkpoint name with an escape", ("\x1b[2J",)))
    return out


def _touch(p: Path) -> Path:
    p.touch()
    return p


def run_values() -> list[Value]:
    def put(rel: str, data: bytes | Callable[[], bytes]) -> Setup:
        return _steps(_copy_fixture("run", "r"), lambda cwd: (cwd / "r" / rel).write_bytes(
            data() if callable(data) else data))

    deep = '{"config": ' + "[" * 100_000 + "]" * 100_000 + "}"
    return [
        Value("a run: best.pt runs code", ("r",), put("best.pt", lambda: _checkpoints()["code that runs"])),
        Value("a run: best.pt deflated from 1.5 GiB", ("r",),
              put("best.pt", lambda: _checkpoints()["a storage record deflated from 1.5 GiB"])),
        Value("a run: best.pt of 3 GiB (sparse file)", ("r",), _steps(
            _copy_fixture("run", "r"), lambda cwd: os.truncate(cwd / "r" / "best.pt", 3 * 2**30))),
        Value("a run: best.pt binary noise", ("r",), put("best.pt", bytes(range(256)) * 4)),
        Value("a run: config.json nested deep", ("r",), put("config.json", deep.encode())),
        Value("a run: config.json asks n_obs 10^9", ("r",), put("config.json", json.dumps(
            {"config": {"model": "odn-l", "n_obs": 10**9, "val": ["tiny.zarr"], "seed": 123},
             "odms_data": "0"}).encode())),
        Value("a run: best.pt a link outside", ("r",), _steps(
            _copy_fixture("run", "r"), lambda cwd: (cwd / "r" / "best.pt").unlink(),
            _link("r/best.pt", "../../outside/thesis.pdf"))),
    ]


def recording_values() -> list[Value]:
    from test_untrusted_imports import png

    return [
        Value("a recording: a mask declaring 200000x200000", ("rec",), _steps(
            _copy_fixture("rec", "rec"), _write("rec/f2.png", png(200000, 200000, idat=b"x")))),
        Value("a recording: a mask of 30000x30000", ("rec",), _steps(
            _copy_fixture("rec", "rec"), _write("rec/f2.png", png(30000, 30000)))),
        Value("a recording: a mask linked outside", ("rec",), _steps(
            _copy_fixture("rec", "rec"), lambda cwd: (cwd / "rec" / "f2.png").unlink(),
            _link("rec/f2.png", "../../outside/thesis.pdf"))),
        Value("a recording: a mask that is a folder", ("rec",), _steps(
            _copy_fixture("rec", "rec"), lambda cwd: (cwd / "rec" / "f2.png").unlink(),
            lambda cwd: (cwd / "rec" / "f2.png").mkdir())),
    ]


def release_values() -> list[Value]:
    from test_untrusted_imports import png

    mask = "release/val/normal/synthetic_1/340000.png"
    return [
        Value("a release: a mask declaring 200000x200000", ("release",), _steps(
            _copy_fixture("release", "release"), _write(mask, png(200000, 200000, idat=b"x")))),
        Value("a release: a mask linked outside", ("release",), _steps(
            _copy_fixture("release", "release"), lambda cwd: (cwd / mask).unlink(),
            _link(mask, "../../../../../outside/thesis.pdf"))),
    ]


def entries_values() -> list[Value]:
    def entry(**change: object) -> bytes:
        base = json.loads((REPO / "leaderboard" / "box_ls.json").read_text())
        base.update(change)
        return json.dumps(base).encode()

    contents = {
        "not JSON": b"{not json", "nested deep": ("[" * 100_000 + "]" * 100_000).encode(),
        "a name with HTML and escapes": entry(name="<script>x</script>\x1b[2J"),
        "a link https://[::1": entry(link="https://[::1"),
        "a javascript: link": entry(link="javascript:alert(1)"),
        "a name with a trailing space": entry(name="Box_LS "),
        "10 MB": b'{"name": "' + b"x" * 10_000_000 + b'"}',
    }
    return [Value(f"entries: {n}", ("entries",), _write("entries/e.json", c)) for n, c in contents.items()]


def config_values() -> list[Value]:
    pairs = zip("abcdefgh", "bcdefghi", strict=True)
    laughs = "a: &a [x, x]\n" + "".join(f"{c}: &{c} [*{p}, *{p}]\n" for p, c in pairs)
    contents = {
        "binary noise": bytes(range(256)) * 4, "empty": b"", "a list": b"- 1\n- 2\n",
        "nested deep": ("a: " + "[" * 30_000 + "]" * 30_000).encode(), "1 MB": b"a: " + b"x" * 2**20,
        "an alias bomb": laughs.encode(), "a python tag": b"fx: !!python/object/apply:os.system [ls]\n",
        "an unknown key": b"num_obs: 10\n", "a derived key": b"z_range: 0.45\n",
        "rotation 1e400": b"rotation: 1e400\n", "num_pos 10^9": b"num_pos: 1000000000\n",
    }
    return [Value(f"config: {n}", ("c.yaml",), _write("c.yaml", c)) for n, c in contents.items()]


def detections_values() -> list[Value]:
    contents = {
        "a line of 10^6 fields": "1," * 10**6 + "1\n",
        "a row of 5 fields": "1,1,2,2,3\n",
        "a NaN width": "1,1,2,2,nan,3,1\n",
        "a frame past the poses": "99,1,2,2,3,3,1\n",
        "bytes that are not text": "1,1,\udcff\n",
    }
    return [Value(f"detections: {n}", ("gt.txt",), _write("gt.txt", c.encode("utf-8", "surrogateescape")))
            for n, c in contents.items()]


REPO = HERE.parents[1]
REBASE = {"checkpoint": (("run", None), ("model", "odn-l")), "poses": (("positions", None),),
          "config": (("params", None), ("box_preset", "odmd"))}
INPUTS: dict[str, Callable[[], list[Value]]] = {
    "store": store_values, "predictions": predictions_values, "positions": positions_values,
    "pickles": pickles_values, "run": run_values, "poses": poses_values,
    "recording": recording_values, "release": release_values, "entries": entries_values,
    "synthia": list, "config": config_values, "detections": detections_values,
}


def output_values(suffix: str) -> list[Value]:
    o = f"o{suffix}"
    return [
        Value("an existing file of the user's", ("thesis.pdf",)),
        Value("a folder of photos", ("photos",)),
        Value("a link to a file outside", (o,), _link(o, "../outside/thesis.pdf")),
        Value("a link to a folder outside", (o,), _link(o, "../outside/photos")),
        Value("a .partial sibling linked outside", (o,), _link(f"{o}.partial", "../outside/photos")),
        Value("a .lock sibling of someone else's", (o,), _write(f"{o}.lock", "not ours\n")),
        Value("memory://", (f"memory://x{suffix}",)),
        Value("s3://", (f"s3://bucket/x{suffix}",)),
        Value("an unknown scheme", (f"nope://bucket/x{suffix}",)),
        Value("http://", (f"http://127.0.0.1:1/x{suffix}",)),
        Value("file://", (f"file:///nonexistent-dir/x{suffix}",)),
        Value("a read-only parent", (f"ro/{o}",), lambda cwd: (cwd / "ro").mkdir(mode=0o555)),
        Value("inside a store", (f"tiny.zarr/{o}",), _copy_fixture("tiny.zarr", "tiny.zarr")),
        Value("/dev/full", ("/dev/full",)),
        Value("/dev/null", ("/dev/null",)),
        Value("a name with an escape", (f"x\x1b[2J{suffix}",)),
        Value("a name of 300 bytes", ("n" * 300 + suffix,)),
        Value("an empty name", ("",)),
        Value("the folder itself", (".",)),
    ]


SCRIPT = "<script>alert(1)</script>"
TEXTS = [
    Value("HTML", ("<img src=x onerror=alert(1)>",), payload="<img src=x onerror"),
    Value("a script", (SCRIPT,), payload=SCRIPT),
    Value("a javascript: link", ("[x](javascript:alert(1))",), payload="](javascript:"),
    Value("a multi-line value with front matter", ("a\n---\nlicense: x\n<script>y</script>",),
          payload="<script>y"),
    Value("a markdown table row", ("a | b\n|---|---|",), payload="|---|"),
    Value("a template", ("{{ 7*7 }}{% raw %}",)),
    Value("a shell substitution", ("$(touch marker-shell)`touch marker-shell`",)),
    Value("a relative path", ("../../outside/x",)),
    Value("terminal escapes", ("\x1b[2J\x1b]0;owned\x07red",)),
    Value("a carriage return", ("ok\rEVIL",)),
    Value("a right-to-left override", ("abc\u202edcba",)),
    Value("10^6 characters", ("a" * 10**6,)),
    Value("a multi-line value", ("line one\nline two",)),
    Value("empty", ("",)),
]
URLS = [Value(f"a URL {u[:40]!r}", (u,)) for u in (
    "javascript:alert(1)", "data:text/html,<script>x</script>", "file:///etc/passwd", "ftp://host/x",
    "ssh://host/x", "memory://x", "s3://bucket/x", "gcs://bucket/x", "http://", "https://[::1",
    "http://127.0.0.1:1", "tcp://127.0.0.1:1", "nope://x", "https://example.com/\x1b[2J", "",
    "https://example.com/" + "a" * 10**6)]
INTS = ["-1", "0", "2147483648", str(2**63), str(10**30), "-" + str(10**30), "nan", "inf", "1e400", "abc",
        "", "1.5", "0x10"]
FLOATS = ["nan", "inf", "-inf", "1e400", "-1e308", "1e308", "0", "-0", "1e-320", "abc", ""]
PAIRS = [("nan", "nan"), ("inf", "1"), ("5", "1"), ("-1e308", "1e308"), ("abc", "1"), ("0", "0")]


def values_for(slot: Slot) -> list[Value]:
    """Every hostile value of the slot's kind."""
    kind, t = kind_of(slot), slot.param.type
    if kind == "flag":
        return [Value("given a value", ())]
    if kind == "choice":
        first = str(t.choices[0])  # type: ignore[attr-defined]
        given = (("not a choice", "nope"), ("upper case", first.upper()), ("a prefix", first[:1]),
                 ("empty", ""), ("an escape", first + "\x1b[2J"), ("10^6 characters", "a" * 10**6))
        return [Value(n, (v,)) for n, v in given]
    if kind == "number":
        if slot.param.nargs == 2:
            return [Value(" ".join(p), p) for p in PAIRS]
        floats = isinstance(t, click.types.FloatParamType)
        return [Value(v or "empty", (v,)) for v in (FLOATS if floats else INTS)]
    if kind == "text":
        return TEXTS
    if kind == "split":
        return split_values()
    if kind == "checkpoint":
        return checkpoint_values()
    if kind == "url":
        return URLS
    if kind == OUT:
        return output_values(ROLES[slot.key][1])
    values = any_input(kind) + INPUTS[kind]()
    return [replace(v, rebase=REBASE[kind]) for v in values] if kind in REBASE else values


# --- cases ------------------------------------------------------------------------------------

@dataclass(frozen=True)
class MatrixCase:
    id: str  # "command --option: value"
    kind: str
    args: tuple[str, ...]
    needs: tuple[str, ...]
    setup: Setup | None
    outputs: tuple[str, ...]  # paths (relative to the working folder) a success may change
    payload: str = ""
    into: tuple[str, ...] = ()  # outputs that are folders the command writes its outputs into


def _argv(command: tuple[str, ...], given: dict[str, str | list[str] | tuple[str, ...]],
          params: list[click.Parameter], valued_flag: str | None = None) -> list[str]:
    """The command line giving each parameter its value; the flag `valued_flag` given `=yes`."""
    options: list[str] = []
    positional: list[str] = []
    for p in params:
        if p.name not in given:
            continue
        v = given[p.name]
        if isinstance(p, click.Argument):
            positional += [v] if isinstance(v, str) else list(v)
            continue
        name = max(p.opts, key=len)
        if isinstance(p, click.Option) and p.is_flag:
            options.append(f"{name}=yes" if p.name == valued_flag else name)
        elif isinstance(v, str):
            options += [name, v]
        elif p.nargs == 2:
            options += [name, *v]
        else:
            for x in v:
                options += [name, x]
    dash = ["--"] if any(x.startswith("-") for x in positional) else []
    return [*command, *options, *dash, *positional]


def cases_of(path: tuple[str, ...], cmd: click.Command) -> Iterator[MatrixCase]:
    command = " ".join(path)
    base, needs = BASES[command]
    params = [p for p in cmd.params if p.name != "help"]
    outputs = tuple(str(v) for k, v in base.items() if ROLES.get(f"{command} {k}", ("",))[0] == OUT)
    into = tuple(str(v) for k, v in base.items() if f"{command} {k}" in INTO)
    if command == "generate":
        outputs += ("generated.zarr",)
    yield MatrixCase(f"{command}: (base)", "base", tuple(_argv(path, base, params)), needs, None, outputs,
                     into=into)
    for p in params:
        slot = Slot(path, p)
        kind = kind_of(slot)
        for value in values_for(slot):
            given = dict(base)
            for name, v in value.rebase:
                given.pop(name, None) if v is None else given.__setitem__(name, v)
            if kind == "flag":
                given[p.name] = "1"
            elif p.nargs == -1 or p.nargs == 2 or (isinstance(p, click.Option) and p.multiple):
                given[p.name] = list(value.args)
            else:
                given[p.name] = value.args[0]
            outs, ins = outputs, into
            if kind == OUT:
                outs = (*[o for o in outputs if o != base.get(p.name)], *value.args)
                ins = value.args if slot.key in INTO else into
            yield MatrixCase(f"{command} {slot.flag or p.name}: {value.name}", kind,
                             tuple(_argv(path, given, params, p.name if kind == "flag" else None)),
                             needs, value.setup, outs, value.payload, ins)


def all_cases() -> list[MatrixCase]:
    return [c for path, cmd in commands().items() for c in cases_of(path, cmd)]


SAMPLE, SEED = 0.03, 37  # the share of the cases CI runs, and the seed that draws them


def sample(cases: list[MatrixCase], share: float = SAMPLE, seed: int = SEED) -> list[MatrixCase]:
    """The bases, and each other case whose id hashes (with the seed) below `share`: a case is drawn
    or not whatever else the matrix holds, so a new option changes no other case's draw."""
    def drawn(c: MatrixCase) -> bool:
        digest = hashlib.sha256(f"{seed}:{c.id}".encode()).digest()
        return int.from_bytes(digest[:8], "big") < share * 2**64

    return [c for c in cases if c.kind == "base" or drawn(c)]


# --- fixtures ---------------------------------------------------------------------------------

class Fixtures:
    """What cases copy, each made the first time a case asks for it."""

    def __init__(self, root: Path) -> None:
        self.root = root
        root.mkdir(parents=True, exist_ok=True)

    def get(self, name: str) -> Path:
        path = self.root / name.replace(":", "_").replace(" ", "_").replace("/", "_")
        if not path.exists():
            self._make(name, path)
        return path

    def _make(self, name: str, path: Path) -> None:  # noqa: C901 (one branch a fixture)
        from broken_stores import DAMAGE, HOSTILE, make_valid

        if name in ("tiny.zarr", "tiny.h5"):
            make_valid(path)
        elif name.startswith("store:"):
            _, damage, backend = name.split(":")
            shutil.copytree(self.get("tiny.zarr"), path) if backend == "zarr" else shutil.copy(
                self.get("tiny.h5"), path)
            {**DAMAGE, **HOSTILE}[damage][1](path)
        elif name == "box.zarr":
            from odms_data.simulate.generate_box_store import generate_box_store

            generate_box_store(str(path), 4, "odmd", 3)
        elif name == "ck.pt":
            shutil.copy(self.get("run") / "best.pt", path)
        elif name == "entries":
            shutil.copytree(REPO / "leaderboard", path)
        elif name == "p.csv":
            path.write_text(PRED + ROWS)
        elif name == "rec":
            from hostile import _recording

            tmp = self.root / "rec-tmp"
            tmp.mkdir()
            _recording(tmp)
            shutil.move(tmp / "rec", path)
            shutil.move(tmp / "positions.csv", self.root / "positions.csv")
            tmp.rmdir()
        elif name == "positions.csv":
            self.get("rec")
        elif name == "gt.txt":
            path.write_text("".join(f"{i + 1},1,{20 - i},{15 - i},{4 + 2 * i},{3 + 2 * i},0.9\n"
                                    for i in range(6)))
        elif name == "poses.txt":
            path.write_text("".join(f"1 0 0 0 0 1 0 0 0 0 1 {0.2 + 0.02 * i:.3f} 0 0 0 1\n"
                                    for i in range(6)))
        elif name == "odmd":
            from importers.test_import_odmd import _odmd_like

            from odms_data.importers.odmd import ODMD_SETS

            p = path / ODMD_SETS["odmd-normal-val"][0]
            p.parent.mkdir(parents=True)
            p.write_bytes(pickle.dumps(_odmd_like(), protocol=3))
        elif name == "release":
            from test_untrusted_imports import release

            release(self.root / "release-tmp")
            shutil.move(self.root / "release-tmp" / "data", path)
        elif name == "synthia":
            from importers.synthia_scenes import street, write_sequence

            tmp = self.root / "synthia-tmp"
            shutil.move(write_sequence(tmp, street(6)), path)
        elif name == "run":
            import torch

            from odms_data.network import odn
            from odms_data.network.variants import variant

            path.mkdir()
            config = {"model": "odn-l", "n_obs": 3, "val": ["tiny.zarr"], "seed": 123}
            (path / "config.json").write_text(json.dumps({"config": config, "odms_data": "0"}))
            torch.save({"iteration": 1, "model": odn.build(variant("odn-l"), 3, False).state_dict()},
                       path / "best.pt")
        elif name == "turn.yaml":
            path.write_text("rotation: 2\n")
        elif name == "photos":
            path.mkdir()
            for i in range(3):
                (path / f"IMG_{i:04d}.jpg").write_bytes(bytes([i]) * 1000)
        elif name == "thesis.pdf":
            path.write_bytes(b"%PDF-1.7 my thesis " * 100)
        else:
            raise KeyError(name)


FIXTURES: Fixtures  # set by `prepare`


def prepare(root: Path) -> Fixtures:
    global FIXTURES
    FIXTURES = Fixtures(root)
    return FIXTURES


# --- running and judging ----------------------------------------------------------------------

def set_up(case: MatrixCase, work: Path) -> Path:
    """A fresh folder for the case: work/<n>/cwd with its fixtures and the markers, and
    work/<n>/outside with the user's files a command must never touch."""
    root = Path(tempfile.mkdtemp(dir=work))
    cwd, outside = root / "cwd", root / "outside"
    cwd.mkdir()
    outside.mkdir()
    for name in ("thesis.pdf", "photos"):
        _copy_fixture(name, name)(outside)
        _copy_fixture(name, name)(cwd)
    for name in case.needs:
        _copy_fixture(name, name)(cwd)
    for name, text in MARKERS.items():
        (cwd / name).write_text(text)
    if case.setup:
        case.setup(cwd)
    return root


CONTROL = {chr(c) for c in range(32)} - {"\n", "\t", "\r"} | {chr(0x7F)} | {chr(c) for c in range(0x80, 0xA0)}


def judge(case: MatrixCase, r: Result, before: dict[str, str], after: dict[str, str], root: Path,
          killed: bool) -> list[str]:
    """The rule every run is judged by; the broken promises (empty: all kept)."""
    markers = sorted(k for k in set(after) - set(before) if Path(k).name.startswith("marker-"))
    outputs = _outputs(case, root)
    after = {k: v for k, v in after.items() if k not in markers}
    if killed:
        progress = [x for x in r.err.splitlines() if x.strip() and not x.startswith("odms-data:")]
        broken = [] if progress else [f"still running after {TIMEOUT:.0f} s and showing no progress"]
        changed = {k for k in set(before) | set(after) if before.get(k) != after.get(k)}
        outside = sorted(k for k in changed if not _in(k, outputs) and not _in(k.rsplit(".", 1)[0], outputs)
                         and ".partial/" not in k)
        broken += [f"changed outside the outputs: {outside[:4]}"] if outside else []
    else:
        honoured = r.rc == 0 and case.kind != "split" or r.rc == 1 and case.args[0] == "validate"
        expect = r.rc if honoured else 2
        as_case = Case("matrix", case.id, list(case.args), expect=expect, outputs=outputs)
        broken = promises_broken(as_case, r, before, after)
    broken += [f"code ran: {', '.join(markers)}"] if markers else []
    raw = sorted({repr(c) for c in r.out + r.err if c in CONTROL})
    broken += [f"raw control characters printed: {', '.join(raw[:5])}"] if raw else []
    if r.max_rss_mb > MEMORY_MIB:
        broken.append(f"peak memory {r.max_rss_mb:.0f} MiB")
    if case.payload and r.rc == 0:
        for o in case.outputs:
            out = root / "cwd" / o
            for p in [out, *out.glob("**/*")] if out.is_dir() else [out]:
                if p.suffix in (".md", ".html", ".htm") and case.payload in p.read_text(errors="replace"):
                    broken.append(f"{p.relative_to(root / 'cwd')} holds {case.payload!r} raw")
    return broken


def _outputs(case: MatrixCase, root: Path) -> tuple[str, ...]:
    """The case's outputs as paths under root; a folder the command writes into may be `.`, and
    may be a link to a folder elsewhere, which it then writes into."""
    out = [f"cwd/{o}" for o in case.outputs if o not in case.into]
    for o in case.into:
        out.append(os.path.normpath(f"cwd/{o}"))
        if os.path.islink(root / "cwd" / o):
            out.append(os.path.relpath(os.path.realpath(root / "cwd" / o), root))
    return tuple(out)


def _in(k: str, outputs: tuple[str, ...]) -> bool:
    return any(k == o or k.startswith(f"{o}/") for o in outputs)


class Server:
    """A process that has imported the command line once and forks one child per case."""

    def __init__(self, fixtures: Fixtures) -> None:
        env = {**os.environ, "OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1"}
        self.proc = subprocess.Popen([sys.executable, str(Path(__file__).resolve()), "--serve",
                                      str(fixtures.root)],
                                     stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True, env=env)
        assert self._read()["ready"]

    def _read(self) -> dict:
        line = self.proc.stdout.readline()  # type: ignore[union-attr]
        if not line:
            raise RuntimeError("the matrix server died")
        return json.loads(line)

    def run(self, args: tuple[str, ...], cwd: Path, timeout: float = TIMEOUT) -> tuple[Result, bool]:
        self.proc.stdin.write(json.dumps({"args": args, "cwd": str(cwd), "timeout": timeout}) + "\n")  # type: ignore[union-attr]
        self.proc.stdin.flush()  # type: ignore[union-attr]
        d = self._read()
        return Result(d["rc"], d["out"], d["err"], d["seconds"], d["peak_mib"]), d["killed"]

    def close(self) -> None:
        self.proc.stdin.close()  # type: ignore[union-attr]
        self.proc.wait(timeout=60)
        self.proc.stdout.close()  # type: ignore[union-attr]


def run_case(case: MatrixCase, server: Server, work: Path) -> tuple[list[str], Result]:
    root = set_up(case, work)
    before = snapshot(root)
    r, killed = server.run(case.args, root / "cwd")
    after = snapshot(root)
    broken = judge(case, r, before, after, root, killed)
    _remove(root)
    return broken, r


def _remove(root: Path) -> None:
    for p in [root, *root.rglob("*")]:
        if p.is_dir() and not p.is_symlink():
            p.chmod(0o755)
    shutil.rmtree(root, ignore_errors=True)


# --- the server -------------------------------------------------------------------------------

def _vm_bytes() -> int:
    return int(open("/proc/self/statm").read().split()[0]) * resource.getpagesize()


def _status(field: str) -> float:
    """A memory figure of /proc/self/status, MiB."""
    for line in open("/proc/self/status"):
        if line.startswith(field + ":"):
            return int(line.split()[1]) / 1024
    return 0.0


def _child(args: list[str], cwd: str, out: str, err: str, result: str) -> None:
    """In the forked child: run the command as `odms-data` does, in its own process group."""
    os.setpgid(0, 0)
    os.chdir(cwd)
    null = os.open(os.devnull, os.O_RDONLY)
    os.dup2(null, 0)
    for fd, path in ((1, out), (2, err)):
        f = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)
        os.dup2(f, fd)
        os.close(f)
    limit = _vm_bytes() + 2 * MEMORY_MIB * 2**20
    resource.setrlimit(resource.RLIMIT_AS, (limit, limit))
    with open("/proc/self/clear_refs", "w") as f:  # the peak counts from here
        f.write("5")
    start = _status("VmRSS")
    from odms_data.cli import main

    code: object = 0
    try:
        main.main(args, prog_name="odms-data")
    except SystemExit as e:
        code = e.code
    except BaseException as e:  # what escaped the command line's own handling
        sys.stderr.write(f"escaped: {type(e).__name__}: {e}\n")
        code = 99
    sys.stdout.flush()
    sys.stderr.flush()
    Path(result).write_text(json.dumps({"peak_mib": _status("VmHWM") - start}))
    os._exit(code if isinstance(code, int) else 1)


def serve() -> None:
    """Read cases (JSON lines) on stdin, answer each with its result."""
    import cv2  # noqa: F401  the heavy imports, once, before any fork
    import h5py  # noqa: F401
    import numpy  # noqa: F401
    import torch  # noqa: F401
    import zarr  # noqa: F401

    from odms_data.cli import COMMANDS

    for module, _ in COMMANDS.values():
        __import__(f"odms_data.cli.{module}")
    io = Path(tempfile.mkdtemp(prefix="matrix-io-"))
    _warm_up(Path(sys.argv[sys.argv.index("--serve") + 1]), io)
    print(json.dumps({"ready": True}), flush=True)
    for line in sys.stdin:
        todo = json.loads(line)
        out, err, result = io / "out", io / "err", io / "result"
        result.unlink(missing_ok=True)
        t = time.perf_counter()
        pid = os.fork()
        if pid == 0:
            _child(todo["args"], todo["cwd"], str(out), str(err), str(result))
        killed, status = _wait(pid, todo["timeout"])
        try:
            os.killpg(pid, signal.SIGKILL)  # what the command left running
        except ProcessLookupError:
            pass
        rc = os.waitstatus_to_exitcode(status)
        rc = 128 - rc if rc < 0 else rc
        peak = json.loads(result.read_text())["peak_mib"] if result.exists() else 0.0
        answer = {"rc": rc, "out": out.read_text(errors="replace"), "err": err.read_text(errors="replace"),
                  "seconds": time.perf_counter() - t, "peak_mib": peak, "killed": killed}
        print(json.dumps(answer), flush=True)
    shutil.rmtree(io, ignore_errors=True)


# run once in the server, so that what they load lazily (modules, compiled kernels) is loaded once
WARM = ("baseline box-ls", "baseline vosde", "convert", "export", "generate", "info", "leaderboard",
        "predict", "score", "show", "validate")


def _warm_up(fixtures: Path, io: Path) -> None:
    from click.testing import CliRunner

    from odms_data.cli import main

    prepare(fixtures)
    here = os.getcwd()
    for case in all_cases():
        if case.kind == "base" and case.id.split(":")[0] in WARM:
            root = set_up(case, io)
            os.chdir(root / "cwd")
            try:
                CliRunner().invoke(main, list(case.args))
            finally:
                os.chdir(here)
                _remove(root)


def _wait(pid: int, timeout: float) -> tuple[bool, int]:
    deadline = time.monotonic() + timeout
    while True:
        done, status = os.waitpid(pid, os.WNOHANG)
        if done:
            return False, status
        if time.monotonic() > deadline:
            os.killpg(pid, signal.SIGKILL)
            return True, os.waitpid(pid, 0)[1]
        select.select([], [], [], 0.005)


def table() -> list[tuple[str, str, str, int]]:
    """(command, parameter, kind, hostile values) for every slot."""
    return [(" ".join(s.command), s.flag or s.param.name or "", kind_of(s), len(values_for(s)))
            for s in slots()]


if __name__ == "__main__":
    if "--serve" in sys.argv:
        serve()
    elif "--list" in sys.argv:
        rows = table()
        for command, name, kind, n in rows:
            print(f"{command:18s} {name:22s} {kind:12s} {n:4d}")
        print(f"{len({r[0] for r in rows})} commands, {len(rows)} parameters, {sum(r[3] for r in rows)} runs "
              f"(+ {len(BASES)} bases)")
