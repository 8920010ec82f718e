"""Property-based: every command with random arguments over random broken stores keeps the
promises of docs/ERRORS.md: exit code 0, 1 (validate), 2 or 130; at most one error line;
nothing outside the output paths touched; no output left half-written."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest
from broken_stores import DAMAGE
from hostile import prepare, run_inprocess, snapshot
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from PIL import Image

from odms_data.evaluation.predictions import read_predictions
from odms_data.store.validate import validate

DAMAGES = sorted(n for n, (backends, _) in DAMAGE.items() if "zarr" in backends.split())
# repeated entries are drawn more often: valid input is common enough for successes to be tested too
INPUTS = ["tiny.zarr", "tiny.zarr", "tiny.h5", "broken.zarr", "broken.zarr", "photos", "thesis.pdf", "empty",
          "missing.zarr", "p.csv", "noise.bin", "/dev/null", "rec"]
PREDICTIONS = ["p.csv", "p.csv", "p.csv", "noise.bin", "thesis.pdf", "/dev/null", "tiny.zarr", "missing.csv"]
OUTPUTS = ["out.zarr", "out.h5", "out.csv", "out.png", "out.json", "out", "out.xyz", "photos", "thesis.pdf",
           "old.csv", "old.png", "old.json", "empty", "tiny.zarr", "other.zarr", "sub/dir/out.zarr",
           "sub/out.png", "p.csv"]
NUMBERS = ["0", "1", "2", "3", "3", "3", "-1", "abc", "1e3", "2.5", str(10**18), ""]
PARAMS = ["d_max=0.5", "d_max=Infinity", "sizes=[5]", "sizes=[]", "perturb_std=3", "n_obs=1",
          "image_size=[0,4]", "colour=1", "d_min", "n_points=[true]", "bezier_radius=[1e9]"]
TINY = ["--param", "image_size=[24,36]", "--param", "sizes=[12,20]", "--workers", "1"]

inputs, outputs, numbers = st.sampled_from(INPUTS), st.sampled_from(OUTPUTS), st.sampled_from(NUMBERS)
flag = st.sampled_from(["--overwrite", "--json", "--markdown", "--allow-partial", "--skip-bad",
                        "--no-verify"])
text = st.text(alphabet="ab/._- 0é", max_size=8)


@st.composite
def command(draw) -> tuple[list[str], list[str]]:
    """(arguments, output paths they name)."""
    which = draw(st.sampled_from(["generate", "info", "validate", "show", "convert", "score", "baseline",
                                  "leaderboard", "import recording", "import odms", "import synthia",
                                  "export"]))
    extra = draw(st.lists(flag, max_size=2))
    out = draw(outputs)
    if which == "generate":
        args = ["generate", "-n", draw(numbers), *TINY, "-o", out,
                *draw(st.lists(st.sampled_from(PARAMS), max_size=2).map(lambda ps: [a for p in ps
                                                                                   for a in ("--param", p)])),
                *draw(st.sampled_from([[], ["--format", "zarr"], ["--format", "hdf5"], ["--seed", "-3"],
                                       ["--n-obs", "1"], ["--preset", "perturb"]]))]
    elif which in ("info", "validate"):
        args, out = [which, draw(inputs)], None
    elif which == "show":
        args = ["show", draw(inputs), draw(st.sampled_from(["tiny/000001", "tiny/9", "", "x"])), "-o", out]
    elif which == "convert":
        args = ["convert", draw(inputs), out, *draw(st.sampled_from([[], ["--format", "zarr"],
                                                                     ["--format", "hdf5"]]))]
    elif which == "score":
        args = ["score", draw(st.sampled_from(PREDICTIONS)), "--data", draw(inputs)]
        args += draw(st.sampled_from([[], ["--plot", out], ["--entry", out, "--name", "Me"]]))
        out = out if len(args) > 4 else None
    elif which == "export":
        args = ["export", draw(inputs), "-o", out]
    elif which == "baseline":
        args = ["baseline", "vosde", draw(inputs), "-o", out, "--n-obs", draw(numbers)]
    elif which == "leaderboard":
        args, out = ["leaderboard", *draw(st.sampled_from([[], ["--dir", "photos"], ["--dir", "empty"],
                                                          ["--family", "val"], ["--metric", "x"]]))], None
    elif which == "import recording":
        positions = draw(st.sampled_from(["positions.csv", "p.csv", "noise.bin"]))
        options = draw(st.sampled_from([[], ["--windows", "2,3"], ["--d1", "-1"], ["--windows", draw(text)]]))
        args = ["import", "recording", draw(inputs), "--positions", positions, "-o", out, "--workers", "1",
                *options]
    else:
        args = ["import", which.split()[1], draw(inputs), "-o", out, "--workers", "1"]
    outs = [] if out is None else [out]
    return args + extra, outs


@pytest.fixture(scope="module")
def fixtures(tmp_path_factory):
    root = prepare(tmp_path_factory.mktemp("any"))
    (root / "noise.bin").write_bytes(bytes(range(256)) * 4)
    return root


def setup_folder(fixtures: Path, work: Path, damage: str) -> None:
    for p in fixtures.iterdir():
        (shutil.copytree if p.is_dir() else shutil.copy)(p, work / p.name)
    shutil.copytree(work / "tiny.zarr", work / "broken.zarr")
    DAMAGE[damage][1](work / "broken.zarr")


def whole(path: Path, command: str, source: Path | None) -> None:
    """A success's output is complete: a valid store (a converted one: as valid as its source), an
    export whose every Parquet file and Croissant file reads, or a file its format reads."""
    if command == "export":
        import pyarrow.parquet as pq

        json.loads((path / "croissant.json").read_text())
        assert sum(pq.read_metadata(f).num_rows for f in path.glob("data/*/*.parquet")) > 0
    elif path.suffix in (".zarr", ".h5") or path.is_dir():
        problems = validate(str(path)).problems
        assert problems == (validate(str(source)).problems if source else []), problems
    elif path.suffix == ".csv":
        read_predictions(path)
    elif path.suffix == ".json":
        json.loads(path.read_text())
    else:
        with Image.open(path) as im:
            im.verify()


@settings(max_examples=100, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(cmd=command(), damage=st.sampled_from(DAMAGES))
def test_any_command_keeps_the_promises(fixtures, tmp_path_factory, cmd, damage):
    args, outs = cmd
    work = tmp_path_factory.mktemp("w")
    setup_folder(fixtures, work, damage)
    before = snapshot(work)
    r = run_inprocess(args, work)
    after = snapshot(work)
    assert r.rc in (0, 1, 2, 130), (args, r.rc, r.err)
    assert "Traceback" not in r.err and "Warning" not in r.err, (args, r.err)
    lines = r.err.strip().splitlines()
    if r.rc in (2, 130):  # an error or an interrupt: one line, last (1 is a verdict, e.g. validate's)
        assert [x for x in lines if x.startswith("odms-data:")] == lines[-1:], (args, r.err)
    if r.rc == 2:
        assert lines[-1].startswith("odms-data: error: "), (args, r.err)
    changed = {k for k in set(before) | set(after) if before.get(k) != after.get(k)}
    if r.rc != 0:
        assert not changed, (args, r.rc, r.err, sorted(changed)[:5])
    else:
        named = [str(Path(o)) for o in outs] + ["generated.zarr"]  # generate's default output
        assert all(any(k == o or k.startswith(o + "/") or o.startswith(k + "/") for o in named)
                   for k in changed), (args, sorted(changed)[:5])
        for o in outs:
            if (work / o).exists() and any(k == o or k.startswith(o + "/") for k in changed):
                whole(work / o, args[0], work / args[1] if args[0] == "convert" else None)
    assert not [k for k in after if k.endswith((".partial", ".lock"))], (args, sorted(after))
