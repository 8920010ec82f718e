"""Every writer, with hostile siblings of its output: links at `<out>.lock`, `.partial` and
`.replaced`, dangling links, foreign folders under those names, names at NAME_MAX.

The promise, each time: refused with one line (exit 2 on the command line) or written correctly,
and nothing outside the output touched: no link followed, no foreign sibling deleted."""

from __future__ import annotations

import json
import os
import resource
import signal
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from odms_data.errors import InputError, OdmsError, OutputLockedError, WriteError
from odms_data.network.checkpoint import Checkpoint
from odms_data.network.run_folder import RUN_OUTPUT, RunFolder, TrainConfig
from odms_data.network.training import _save, train
from odms_data.outputs import MARKER, NAME_MAX, output_lock, replaced_via_partial, sibling, write_text
from odms_data.publish.contact_sheet import save_image
from odms_data.simulate.generate_store import generate
from odms_data.simulate.params import PRESETS
from odms_data.store.reader import open_store

Writer = Callable[[Path, bool], None]  # (output, overwrite)


def _text(out: Path, overwrite: bool) -> None:
    write_text(out, '{"entry": 1}\n', overwrite=overwrite)


def _png(out: Path, overwrite: bool) -> None:
    save_image(Image.fromarray(np.zeros((4, 4), np.uint8)), out, overwrite=overwrite)


def _store(fmt: str) -> Writer:
    def write(out: Path, overwrite: bool) -> None:
        generate(str(out), 2, PRESETS["standard"], 5, fmt=fmt, workers=1, overwrite=overwrite)

    return write


WRITERS = {  # output name: writer
    "entry.json": _text,
    "v.csv": _text,
    "sheet.png": _png,
    "g.zarr": _store("zarr"),
    "g.h5": _store("hdf5"),
}
FOLDER_OUTPUTS = {"g.zarr"}


def _written(out: Path) -> bool:
    if out.suffix in (".zarr", ".h5"):
        with open_store(str(out)) as s:
            return s.n_examples == 2
    return out.is_file() and out.stat().st_size > 0


def _victim(tmp_path: Path) -> tuple[Path, Path]:
    """A file and a folder of the user's, outside the output, that must stay as they are."""
    outside = tmp_path / "elsewhere"
    outside.mkdir()
    thesis = outside / "thesis.pdf"
    thesis.write_bytes(b"%PDF years of work")
    photos = outside / "photos"
    photos.mkdir()
    (photos / "cat.jpg").write_bytes(b"\xff\xd8 cat")
    return thesis, photos


def _untouched(thesis: Path, photos: Path) -> None:
    assert thesis.read_bytes() == b"%PDF years of work"
    assert [p.name for p in photos.iterdir()] == ["cat.jpg"]
    assert (photos / "cat.jpg").read_bytes() == b"\xff\xd8 cat"
    assert sorted(p.name for p in thesis.parent.iterdir()) == ["photos", "thesis.pdf"]


def _one_line(e: pytest.ExceptionInfo) -> str:
    message = str(e.value)
    assert "\n" not in message
    return message


@pytest.mark.parametrize("name", WRITERS)
@pytest.mark.parametrize("suffix", [".lock", ".partial", ".replaced"])
@pytest.mark.parametrize("link", ["to a file", "to a folder", "dangling"])
def test_a_link_at_a_sibling_is_never_followed(tmp_path, name, suffix, link):
    thesis, photos = _victim(tmp_path)
    out = tmp_path / name
    if suffix == ".replaced":
        WRITERS[name](out, False)  # .replaced is used only when replacing
    to = {"to a file": thesis, "to a folder": photos, "dangling": tmp_path / "elsewhere" / "new"}[link]
    os.symlink(to, sibling(out, suffix))
    overwrite = suffix == ".replaced"
    if suffix == ".replaced" and name not in FOLDER_OUTPUTS:
        WRITERS[name](out, overwrite)  # a file replaces a file in one rename: the sibling is not used
        assert _written(out)
    else:
        with pytest.raises(OdmsError) as e:
            WRITERS[name](out, overwrite)
        assert str(sibling(out, suffix)) in _one_line(e)
    assert os.path.islink(sibling(out, suffix))  # not deleted either
    _untouched(thesis, photos)


@pytest.mark.parametrize("name", WRITERS)
@pytest.mark.parametrize("suffix", [".partial", ".replaced"])
def test_a_foreign_folder_named_like_a_sibling_is_kept(tmp_path, name, suffix):
    out = tmp_path / name
    if suffix == ".replaced":
        WRITERS[name](out, False)
    foreign = sibling(out, suffix)
    foreign.mkdir()
    (foreign / "holiday.jpg").write_bytes(b"sea")
    if suffix == ".replaced" and name not in FOLDER_OUTPUTS:
        WRITERS[name](out, True)
    else:
        with pytest.raises(OdmsError, match="did not make"):
            WRITERS[name](out, suffix == ".replaced")
    assert [p.name for p in foreign.iterdir()] == ["holiday.jpg"]


@pytest.mark.parametrize("name", WRITERS)
def test_a_lock_that_is_not_ours_is_refused_and_kept(tmp_path, name):
    out = tmp_path / name
    lock = sibling(out, ".lock")
    lock.write_text("my notes, not a process id")
    with pytest.raises(OdmsError, match="is not an odms-data lock"):
        WRITERS[name](out, False)
    assert lock.read_text() == "my notes, not a process id" and not out.exists()
    lock.unlink()
    os.link(_victim(tmp_path)[0], lock)  # a hard link to the user's file: never truncated
    with pytest.raises(OdmsError, match="is not an odms-data lock"):
        WRITERS[name](out, False)
    assert lock.read_bytes() == b"%PDF years of work"


@pytest.mark.parametrize("name", WRITERS)
def test_stale_siblings_of_ours_are_taken_over(tmp_path, name):
    """What a killed run leaves (a lock holding its pid, a marked or empty .partial) is not in the
    way of the next run."""
    out = tmp_path / name
    sibling(out, ".lock").write_text("999999")
    partial = sibling(out, ".partial")
    partial.mkdir()
    (partial / MARKER).write_text("odms-data 999999 x\n")
    (partial / "half").write_bytes(b"half")
    WRITERS[name](out, False)
    assert _written(out) and sorted(p.name for p in tmp_path.iterdir()) == [name]
    partial.mkdir()  # killed between mkdir and the marker: empty
    WRITERS[name](out, True)
    assert _written(out) and sorted(p.name for p in tmp_path.iterdir()) == [name]


@pytest.mark.parametrize("name", WRITERS)
def test_a_name_at_name_max_is_written_and_replaced(tmp_path, name):
    ext = name[name.index("."):]
    n = 252 - len(ext)  # a legal name, whose siblings' suffixes would pass NAME_MAX
    long = tmp_path / ("é" * (n // 2) + "x" * (n % 2) + ext)
    assert len(os.fsencode(long.name)) == 252
    WRITERS[name](long, False)
    WRITERS[name](long, True)
    assert _written(long) and [p.name for p in tmp_path.iterdir()] == [long.name]
    for suffix in (".lock", ".partial", ".replaced"):
        s = sibling(long, suffix)
        assert len(os.fsencode(s.name)) <= NAME_MAX and s.name.endswith(suffix) and s.parent == long.parent


def test_sibling_names_are_shortened_only_when_needed_and_stay_distinct(tmp_path):
    assert sibling(tmp_path / "v.csv", ".lock") == tmp_path / "v.csv.lock"
    a, b = ("a" * 252 + ".csv")[:252], ("a" * 251 + "b")
    assert len(sibling(tmp_path / a, ".partial").name.encode()) <= NAME_MAX
    assert sibling(tmp_path / a, ".partial") != sibling(tmp_path / b, ".partial")


def test_two_training_runs_into_one_folder_are_refused(tmp_path):
    run = tmp_path / "run"
    config = TrainConfig(iterations=1, batch_size=2, val=(str(tmp_path / "v.zarr"),))
    with output_lock(run, RUN_OUTPUT), pytest.raises(OutputLockedError, match="is writing this training run"):
        train(run, config, workers=0, device="cpu")
    assert not run.exists()


def test_overwrite_replaces_only_a_run_that_odms_data_wrote(tmp_path):
    app = tmp_path / "webapp"
    app.mkdir()
    (app / "config.json").write_text('{"port": 8080, "config": {}}')
    (app / "index.html").write_text("<html>")
    config = TrainConfig(iterations=1, batch_size=2, val=("v.zarr",))
    for overwrite in (False, True):
        with pytest.raises(InputError, match="holds no training run"):
            RunFolder(app).check(config, overwrite)
    assert sorted(p.name for p in app.iterdir()) == ["config.json", "index.html"]
    RunFolder(tmp_path / "run").create(config, False)
    assert RunFolder(tmp_path / "run").is_run() and RunFolder(tmp_path / "run").check(config, True) is False


def test_no_run_is_written_inside_a_store(tmp_path):
    store = tmp_path / "s.zarr"
    generate(str(store), 2, PRESETS["standard"], 5, workers=1)
    config = TrainConfig(iterations=1, batch_size=2, val=(str(store),))
    with pytest.raises(InputError, match="inside the Zarr store"):
        train(store / "run", config, workers=0, device="cpu")
    assert not (store / "run").exists() and not (store / "run.lock").exists()


def test_a_full_disk_while_saving_a_checkpoint_is_one_line(tmp_path):
    import torch

    last = tmp_path / "last.pt"
    _save(last, Checkpoint(1, {}))
    old = last.read_bytes()
    limits = resource.getrlimit(resource.RLIMIT_FSIZE)
    handler = signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
    resource.setrlimit(resource.RLIMIT_FSIZE, (len(old) + 4096, limits[1]))
    try:
        with pytest.raises(WriteError) as e:
            _save(last, Checkpoint(2, {"w": torch.zeros(100_000)}))
    finally:
        resource.setrlimit(resource.RLIMIT_FSIZE, limits)
        signal.signal(signal.SIGXFSZ, handler)
    assert _one_line(e).startswith(f"{last}: cannot be written: the file size limit was reached")
    assert last.read_bytes() == old and [p.name for p in tmp_path.iterdir()] == ["last.pt"]


def test_a_file_replaced_as_it_goes_never_writes_through_a_link(tmp_path):
    thesis, photos = _victim(tmp_path)
    out = tmp_path / "best.pt"
    os.symlink(photos, sibling(out, ".partial"))
    with pytest.raises(OdmsError, match="did not make"), replaced_via_partial(out) as partial:
        partial.write_bytes(b"weights")
    _untouched(thesis, photos)


def _cli(*args: str, cwd: Path) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "odms_data.cli", *args], capture_output=True, text=True,
                          cwd=cwd)


def _refused(r: subprocess.CompletedProcess, *fragments: str) -> None:
    """Exit 2, and one error line, the last (progress lines may come before it), no traceback."""
    lines = r.stderr.strip().splitlines()
    errors = [line for line in lines if line.startswith("odms-data:")]
    assert r.returncode == 2 and errors == lines[-1:] and "Traceback" not in r.stderr, r.stderr
    assert errors[0].startswith("odms-data: error: ") and all(f in errors[0] for f in fragments), errors[0]


def test_the_command_line_keeps_the_promise(tmp_path):
    """The issue's cases, as a user runs them: a lock linked to a thesis, a folder of photos named
    like the partial store, and both again with --overwrite."""
    thesis, photos = _victim(tmp_path)
    generate(str(tmp_path / "s.zarr"), 2, PRESETS["standard"], 5, workers=1)
    os.symlink(thesis, tmp_path / "v.csv.lock")
    _refused(_cli("baseline", "vosde", "s.zarr", "-o", "v.csv", cwd=tmp_path), "v.csv.lock",
             "not an odms-data lock")
    os.symlink(photos, tmp_path / "g.zarr.partial")
    _refused(_cli("generate", "-n", "2", "-o", "g.zarr", "--workers", "1", cwd=tmp_path), "g.zarr.partial")
    _untouched(thesis, photos)
    assert not (tmp_path / "v.csv").exists() and not (tmp_path / "g.zarr").exists()
    (tmp_path / "g.zarr.partial").unlink()
    (tmp_path / "g.zarr.partial").mkdir()
    (tmp_path / "g.zarr.partial" / "dog.jpg").write_bytes(b"dog")
    _refused(_cli("generate", "-n", "2", "-o", "g.zarr", "--workers", "1", cwd=tmp_path), "did not make")
    assert json.dumps(sorted(p.name for p in (tmp_path / "g.zarr.partial").iterdir())) == '["dog.jpg"]'


def test_train_stopped_by_sigterm_exits_143(tmp_path):
    """The CLI's rule (128 + the signal) holds for `train` too, which says where it resumes."""
    generate(str(tmp_path / "v.zarr"), 4, PRESETS["standard"], 5, workers=1)
    p = subprocess.Popen([sys.executable, "-m", "odms_data.cli", "train", "-o", "run", "--val", "v.zarr",
                          "--iterations", "100000", "--batch-size", "2", "--workers", "0", "--device", "cpu"],
                         cwd=tmp_path, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    while not (tmp_path / "run" / "curves.csv").exists() and p.poll() is None:
        time.sleep(0.05)
    p.send_signal(signal.SIGTERM)
    _, err = p.communicate(timeout=120)
    assert p.returncode == 143, err
    assert err.strip().splitlines()[-1].startswith("odms-data: interrupted (SIGTERM); rerun the same command")
    assert "Traceback" not in err and not (tmp_path / "run.lock").exists()
