"""The odms-data command line, run as users run it: subprocesses with real files."""

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from PIL import Image

from odms_data.simulate.generate_store import generate
from odms_data.simulate.params import PRESETS
from odms_data.store.reader import open_store
from odms_data.store.validate import validate


def odms(*args: str, cwd: Path | None = None) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "odms_data.cli", *args], capture_output=True, text=True, cwd=cwd
    )


def assert_one_line_error(result: subprocess.CompletedProcess, *fragments: str) -> None:
    assert result.returncode == 2, result.stderr
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("odms-data: error: "), result.stderr
    assert "Traceback" not in result.stderr
    for f in fragments:
        assert f in lines[0], lines[0]


def test_generate_named_split_matches_its_manifest(tmp_path):
    out = tmp_path / "sim-val.zarr"
    r = odms("generate", "--split", "sim-val", "-o", str(out), "--workers", "2")
    assert r.returncode == 0, r.stderr
    assert "digest matches splits/sim-val.json" in r.stdout
    assert open_store(str(out)).n_examples == 2000


def test_info_show_and_validate(tmp_path):
    out = tmp_path / "s.h5"
    assert odms("generate", "-n", "12", "--preset", "perturb", "--seed", "3", "--n-obs", "5",
                "-o", str(out)).returncode == 0
    info = odms("info", str(out))
    assert info.returncode == 0
    assert "12 (12 labelled), frames 60" in info.stdout and "hdf5" in info.stdout
    assert "preset perturb, seed 3" in info.stdout
    sheet = tmp_path / "sheet.png"
    r = odms("show", str(out), "generated/000004", "-o", str(sheet))
    assert r.returncode == 0, r.stderr
    with Image.open(sheet) as im:
        assert im.width > 500 and im.height > 100
    v = odms("validate", str(out))
    assert v.returncode == 0 and "valid" in v.stdout


def test_validate_exits_1_and_lists_problems(tmp_path):
    out = tmp_path / "s.zarr"
    assert odms("generate", "-n", "4", "-o", str(out)).returncode == 0
    (out / "d1" / "c" / "0").unlink()
    v = odms("validate", str(out))
    assert v.returncode == 1
    assert "problem:" in v.stdout and "INVALID" in v.stdout


def test_validate_and_info_take_several_stores(tmp_path):
    import json

    a, b = tmp_path / "a.zarr", tmp_path / "b.h5"
    generate(str(a), 3, PRESETS["standard"], 1, workers=1)
    generate(str(b), 4, PRESETS["perturb"], 2, split="other", workers=1)
    info = odms("info", str(a), str(b))
    assert info.returncode == 0, info.stderr
    assert f"store       {a} (zarr" in info.stdout and f"store       {b} (hdf5" in info.stdout
    assert "split       generated" in info.stdout and "split       other" in info.stdout
    both = json.loads(odms("info", str(a), str(b), "--json").stdout)
    assert [(s["path"], s["counts"]["examples"]) for s in both["stores"]] == [(str(a), 3), (str(b), 4)]
    v = odms("validate", str(a), str(b))
    assert v.returncode == 0 and v.stdout.count(": valid, digest sha256:") == 2, v.stdout
    (a / "d1" / "c" / "0").unlink()
    v = odms("validate", str(a), str(b), "--json")
    assert v.returncode == 1
    assert [r["ok"] for r in json.loads(v.stdout)["stores"]] == [False, True]


@pytest.mark.parametrize("args,fragments", [
    (["generate"], ["give --split NAME or -n COUNT"]),
    (["generate", "--split", "sim-nope"], ["unknown split 'sim-nope'", "sim-val"]),
    (["generate", "--split", "sim-val", "-n", "3"], ["drop -n"]),
    (["generate", "-n", "2", "--param", "d_min=abc"], ["not a number or JSON list"]),
    (["generate", "-n", "2", "--param", 'd_min="abc"'], ["d_min must be a number > 0 and <= 1e+06"]),
    (["generate", "-n", "2", "--param", "colour=1"], ["unknown name(s) colour"]),
    (["generate", "-n", "2", "--param", "d_min"], ["expected NAME=VALUE"]),
    (["generate", "-n", "2", "--param", "d_max=0.15"], ["dz_min"]),
    (["info", "nowhere.zarr"], ["nowhere.zarr: no such store"]),
    (["validate", "nowhere.zarr"], []),
    (["show", "nowhere.zarr", "x", "-o", "x.png"], ["no such store"]),
])
def test_bad_arguments_get_one_line_and_exit_2(tmp_path, args, fragments):
    r = odms(*args, cwd=tmp_path)
    if args[0] == "validate":
        assert r.returncode == 1 and "problem: nowhere.zarr: no such store" in r.stdout  # the path once
        return
    assert_one_line_error(r, *fragments)


def test_existing_output_and_unknown_example(tmp_path):
    out = tmp_path / "s.zarr"
    assert odms("generate", "-n", "2", "-o", str(out)).returncode == 0
    assert_one_line_error(odms("generate", "-n", "2", "-o", str(out)), "already exists", "--overwrite")
    assert_one_line_error(odms("show", str(out), "generated/000009", "-o", "x.png", cwd=tmp_path),
                          "no example 'generated/000009'")
    assert_one_line_error(odms("convert", str(out), str(out)), "already exists")


def test_help_of_every_command_has_an_example():
    for cmd in ("generate", "validate", "info", "convert", "show", "export"):
        r = odms(cmd, "--help")
        assert r.returncode == 0 and "Example" in r.stdout and "odms-data " + cmd in r.stdout


@pytest.mark.parametrize("suffix", [".zarr", ".h5"])
def test_killed_generation_never_looks_complete_and_reruns_cleanly(tmp_path, suffix):
    out = tmp_path / f"big{suffix}"
    args = ["generate", "-n", "1500", "--seed", "4", "-o", str(out), "--workers", "1",
            "--examples-per-shard", "50"]
    proc = subprocess.Popen([sys.executable, "-m", "odms_data.cli", *args],
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    partial = Path(str(out) + ".partial")
    deadline = time.monotonic() + 60
    while not partial.exists() and time.monotonic() < deadline:
        time.sleep(0.05)
    time.sleep(0.3)
    os.kill(proc.pid, signal.SIGKILL)
    proc.wait()
    assert not out.exists()
    assert not validate(str(out)).ok
    rerun = odms(*args)
    assert rerun.returncode == 0, rerun.stderr
    assert not partial.exists()
    reference = generate(str(tmp_path / "ref.zarr"), 1500, PRESETS["standard"], 4, workers=2)
    assert open_store(str(out)).attrs.digest == reference.digest


def test_every_reporting_command_speaks_json_and_shows_progress_in_logs(tmp_path):
    """--json on every command that reports; with stderr not a terminal, progress comes as lines."""
    import json

    store, h5 = tmp_path / "s.zarr", tmp_path / "s.h5"
    runs = {
        "generate": odms("generate", "-n", "6", "--n-obs", "4", "-o", str(store), "--json"),
        "convert": odms("convert", str(store), str(h5), "--json"),
        "info": odms("info", str(h5), "--json"),
        "validate": odms("validate", str(h5), "--json"),
        "baseline": odms("baseline", "vosde", str(store), "--n-obs", "4", "-o", str(tmp_path / "p.csv"),
                         "--json"),
        "leaderboard": odms("leaderboard", "--json"),
        "export": odms("export", str(store), "-o", str(tmp_path / "hub"), "--json"),
    }
    out = {name: json.loads(r.stdout) for name, r in runs.items()}
    assert out["generate"]["examples"] == 6 and out["convert"]["digest"] == out["generate"]["digest"]
    assert out["info"]["example_ids"] == {"first": "generated/000000", "last": "generated/000005"}
    assert out["validate"]["ok"] and out["baseline"]["splits"][0]["examples"] == 6
    assert out["leaderboard"][0]["rank"] == 1 and out["export"]["splits"][0]["examples"] == 6
    for name, label in (("generate", "generating"), ("convert", "converting"), ("validate", "validating"),
                        ("export", "exporting")):
        assert runs[name].stderr.splitlines()[-1].endswith(" elapsed") and label in runs[name].stderr
    assert "6/6 (100%)" in runs["generate"].stderr
    for group, cmd in (("import", "odms"), ("import", "recording"), ("score", None)):
        r = odms(*filter(None, (group, cmd)), "--help")
        assert "--json" in r.stdout, (group, cmd)


def test_a_store_named_without_a_suffix_is_scored(tmp_path):
    """generate writes a Zarr store wherever -o points; score --data must take it as a store."""
    store, preds = tmp_path / "mine", tmp_path / "p.csv"
    assert odms("generate", "-n", "3", "--n-obs", "3", "-o", str(store)).returncode == 0
    assert odms("baseline", "vosde", str(store), "--n-obs", "3", "-o", str(preds)).returncode == 0
    r = odms("score", str(preds), "--data", str(store))
    assert r.returncode == 0, r.stderr
    assert "generated" in r.stdout and "3" in r.stdout


def test_did_you_mean(tmp_path):
    store = tmp_path / "s.zarr"
    assert odms("generate", "-n", "3", "--n-obs", "3", "-o", str(store)).returncode == 0
    assert_one_line_error(odms("show", str(store), "000002", "-o", str(tmp_path / "x.png")),
                          "did you mean generated/000002?")
    assert_one_line_error(odms("generate", "--split", "sim-vall"), "did you mean sim-val?")
    (tmp_path / "ODMS" / "data" / "val").mkdir(parents=True)
    assert_one_line_error(odms("import", "odms", str(tmp_path / "ODMS"), "-o", str(tmp_path / "out")),
                          f"did you mean {tmp_path / 'ODMS' / 'data'}?")
    r = odms("generat")
    assert r.returncode == 2 and "Did you mean 'generate'?" in r.stderr
    assert "generated/000000 .. generated/000002" in odms("info", str(store)).stdout


def test_help_names_the_environment_and_completion():
    r = odms("--help")
    for word in ("ODMS_DATA", "ODMS_DEBUG", "ODMS_SHARED", "_ODMS_DATA_COMPLETE=bash_source"):
        assert word in r.stdout
    env = {**os.environ, "_ODMS_DATA_COMPLETE": "bash_complete", "COMP_WORDS": "odms-data expo",
           "COMP_CWORD": "1"}
    done = subprocess.run([sys.executable, "-m", "odms_data.cli"], env=env, capture_output=True, text=True)
    assert "plain,export" in done.stdout.splitlines()


def _completions(words: str, cwd: Path) -> list[str]:
    cword = len(words.split()) - (0 if words.endswith(" ") else 1)
    env = {**os.environ, "_ODMS_DATA_COMPLETE": "bash_complete", "COMP_WORDS": words,
           "COMP_CWORD": str(cword)}
    done = subprocess.run([sys.executable, "-m", "odms_data.cli"], env=env, capture_output=True, text=True,
                          cwd=cwd)
    return done.stdout.splitlines()


def test_completion_offers_split_names_and_store_paths(tmp_path):
    (tmp_path / "runs" / "old.zarr").mkdir(parents=True)
    (tmp_path / "sim-val.zarr").mkdir()
    (tmp_path / "train.h5").write_bytes(b"")
    (tmp_path / "notes.txt").write_text("not a store")
    assert _completions("odms-data generate --split sim-v", tmp_path) == ["plain,sim-val"]
    stores = ["plain,runs/", "plain,sim-val.zarr", "plain,train.h5"]
    assert _completions("odms-data info ", tmp_path) == stores
    assert _completions("odms-data validate runs/", tmp_path) == ["plain,runs/old.zarr"]
    assert _completions("odms-data baseline vosde robot-t", tmp_path) == ["plain,robot-test"]


def test_output_into_a_closed_pipe_stops_quietly(tmp_path):
    """`odms-data info … | head` whose reader is gone: no error line, no traceback, SIGPIPE's code."""
    out = tmp_path / "s.zarr"
    assert odms("generate", "-n", "4", "-o", str(out)).returncode == 0
    read, write = os.pipe()
    os.close(read)  # the reader went away before the command wrote
    try:
        r = subprocess.run([sys.executable, "-m", "odms_data.cli", "info", str(out)], stdout=write,
                           stderr=subprocess.PIPE, text=True)
    finally:
        os.close(write)
    assert r.returncode == 128 + signal.SIGPIPE and r.stderr == ""
