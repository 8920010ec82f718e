"""The rules every output follows (odms_data.outputs), on their own."""

from __future__ import annotations

import errno
import hashlib
import os
import signal
import subprocess
import sys
import threading
import time

import pytest

from odms_data import outputs
from odms_data.errors import InputError, Interrupted, OutputExistsError, WriteError
from odms_data.evaluation.predictions import read_predictions
from odms_data.interrupts import stop_requested, uninterrupted
from odms_data.outputs import (
    atomic_file,
    atomic_folder,
    check_replaceable,
    replaced_via_partial,
    write_text,
)
from odms_data.store.writer import StoreWriter


def test_a_failed_write_keeps_the_old_file_and_leaves_nothing(tmp_path):
    out = tmp_path / "r.csv"
    out.write_text("old")
    with pytest.raises(RuntimeError), atomic_file(out, overwrite=True) as partial:
        partial.write_text("half")
        raise RuntimeError("the writer failed")
    assert out.read_text() == "old"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["r.csv"]
    write_text(out, "new", overwrite=True)
    assert out.read_text() == "new" and sorted(p.name for p in tmp_path.iterdir()) == ["r.csv"]


def test_a_file_replaced_as_it_goes_survives_a_full_disk(tmp_path):
    """What a training run does with its checkpoints: no existence check, the same safety."""
    import errno

    out = tmp_path / "last.pt"
    out.write_bytes(b"iteration 10")
    full = pytest.raises(WriteError, match="last.pt: cannot be written: no space")
    with full, replaced_via_partial(out) as partial:
        partial.write_bytes(b"iteration 2")
        raise OSError(errno.ENOSPC, "No space left on device", str(partial))
    assert out.read_bytes() == b"iteration 10" and [p.name for p in tmp_path.iterdir()] == ["last.pt"]
    with replaced_via_partial(out) as partial:
        partial.write_bytes(b"iteration 20")
    assert out.read_bytes() == b"iteration 20" and [p.name for p in tmp_path.iterdir()] == ["last.pt"]


def test_existing_paths_folders_and_suffixes_are_refused(tmp_path):
    (tmp_path / "a.csv").write_text("x")
    with pytest.raises(OutputExistsError, match="already exists") as refused:
        check_replaceable(tmp_path / "a.csv", False, option="-o")
    assert refused.value.fix == "overwrite"
    with pytest.raises(OutputExistsError, match="is a folder"):
        check_replaceable(tmp_path, True, option="-o")
    with pytest.raises(InputError, match=r"name the file \*\.csv"):
        check_replaceable(tmp_path / "a.zarr", False, option="-o", suffixes=(".csv",))
    check_replaceable(tmp_path / "a.csv", True, option="-o", suffixes=(".csv",))


def test_folders_made_for_a_failed_output_are_removed(tmp_path):
    with pytest.raises(RuntimeError), atomic_file(tmp_path / "x" / "y" / "r.csv"):
        raise RuntimeError
    assert list(tmp_path.iterdir()) == []


def test_a_stop_signal_waits_for_the_write_in_progress():
    previous = signal.signal(signal.SIGTERM, lambda signum, frame: stop_requested(signum))
    done = []
    try:
        with pytest.raises(Interrupted) as e:
            with uninterrupted():
                os.kill(os.getpid(), signal.SIGTERM)
                done.append("the write finished")
        assert done and e.value.signum == signal.SIGTERM
    finally:
        signal.signal(signal.SIGTERM, previous)


def test_a_ctrl_c_with_pythons_own_handler_waits_for_the_write_in_progress():
    """Used as a library, without the command line's handler: the signal is held, not deferred,
    and the next stop outside a block is not held."""
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    done = []
    try:
        with pytest.raises(KeyboardInterrupt):
            with uninterrupted():
                signal.raise_signal(signal.SIGINT)  # to this thread, as a terminal's Ctrl-C reaches a script
                time.sleep(0.01)
                done.append("the write finished")
        assert done
        signal.signal(signal.SIGINT, lambda signum, frame: stop_requested(signum))
        with pytest.raises(Interrupted):
            signal.raise_signal(signal.SIGINT)
            time.sleep(0.01)
            done.append("the stop was deferred")
        assert done == ["the write finished"]
    finally:
        signal.signal(signal.SIGINT, previous)


RUN = outputs.OutputType("run", lambda p: None)


def _old_output(tmp_path):
    out = tmp_path / "run"
    out.mkdir()
    (out / "old").write_text("the old output")
    return out


@pytest.fixture
def stop_from_another_thread(monkeypatch):
    """`stop_after(name, call)`: a SIGTERM, handled as the command line handles it, comes right
    after outputs.<name>'s `call`-th call returns, by way of another thread (zarr's I/O thread, a
    pool's), where a signal mask on the main thread does not hold it off."""
    previous = signal.signal(signal.SIGTERM, lambda signum, frame: stop_requested(signum))
    other = threading.Thread(target=threading.Event().wait, args=(60,), daemon=True)
    other.start()

    def stop_after(name: str, call: int) -> None:
        original, calls = getattr(outputs, name), []

        def then_stop(*args):
            result = original(*args)
            calls.append(name)
            if len(calls) == call:
                signal.pthread_kill(other.ident, signal.SIGTERM)
                for _ in range(100):  # each call runs the handler, in this thread, once the signal is there
                    signal.pthread_kill(other.ident, 0)
                    time.sleep(0.001)
            return result
        monkeypatch.setattr(outputs, name, then_stop)

    yield stop_after
    signal.signal(signal.SIGTERM, previous)


@pytest.mark.parametrize(("step", "call"), [("_open_lock", 1), ("_make_sibling_folder", 1),
                                            ("_make_sibling_folder", 2)],
                         ids=["lock made", "partial made", "old output set aside"])
def test_a_stop_as_a_sibling_is_made_leaves_no_sibling(tmp_path, stop_from_another_thread, step, call):
    """Each sibling of an output (the lock, `.partial`, the `.replaced` holding the old output) is
    removed again by a stop that comes right after it is made: the stop waits until its removal is
    set, or until the output is in place."""
    out = _old_output(tmp_path)
    stop_from_another_thread(step, call)
    with pytest.raises(Interrupted), atomic_folder(out, RUN, overwrite=True) as new:
        (new / "new").write_text("the new output")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run"]
    assert [p.name for p in out.iterdir()] == (["new"] if call == 2 else ["old"])


def test_a_store_writer_stopped_as_its_partial_store_is_made_leaves_nothing(
    tmp_path, stop_from_another_thread
):
    stop_from_another_thread("_make_sibling_folder", 1)
    with pytest.raises(Interrupted), StoreWriter(str(tmp_path / "s.zarr")):
        pass
    assert list(tmp_path.iterdir()) == []


KILLED_BETWEEN_THE_RENAMES = """
import os, signal, sys
from pathlib import Path
from odms_data import outputs

out = Path(sys.argv[1])
rename = os.rename

def killed_at_the_second(src, dst):
    if Path(dst) == out:  # the old output is set aside; the new one is about to take its place
        os.kill(os.getpid(), signal.SIGKILL)
    rename(src, dst)

os.rename = killed_at_the_second
with outputs.atomic_folder(out, outputs.OutputType("run", lambda p: None), overwrite=True) as new:
    (new / "new").write_text("the new output")
"""


def test_an_old_output_set_aside_by_a_killed_commit_is_put_back(tmp_path):
    """kill -9 between a commit's two renames leaves the old output in `<out>.replaced`; the next
    write of `out` puts it back before anything else (here it is then refused: it exists)."""
    out = _old_output(tmp_path)
    p = subprocess.run([sys.executable, "-c", KILLED_BETWEEN_THE_RENAMES, str(out)], timeout=120)
    assert p.returncode == -signal.SIGKILL and not out.exists()
    assert (tmp_path / "run.replaced" / "run" / "old").read_text() == "the old output"
    with pytest.raises(OutputExistsError), atomic_folder(out, RUN):
        pass
    assert [f.read_text() for f in out.iterdir()] == ["the old output"]
    assert not (tmp_path / "run.replaced").exists()


def test_a_failed_rename_into_place_puts_the_old_output_back(tmp_path, monkeypatch):
    out = _old_output(tmp_path)
    rename = os.rename

    def failing_into_place(src, dst):  # the new output's rename only
        if os.fspath(src) == f"{out}.partial":
            raise OSError(errno.EIO, "Input/output error", os.fspath(src))
        rename(src, dst)

    monkeypatch.setattr(os, "rename", failing_into_place)
    with pytest.raises(WriteError, match="run: cannot be written: Input/output error"):
        with atomic_folder(out, RUN, overwrite=True) as new:
            (new / "new").write_text("the new output")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run"]
    assert [f.read_text() for f in out.iterdir()] == ["the old output"]


def test_the_predictions_hash_is_the_files(tmp_path):
    p = tmp_path / "p.csv"
    p.write_text("split,example_id,d1\n" + "".join(f"s,s/{i},{i}.5\n" for i in range(5000)))
    assert read_predictions(p).sha256 == hashlib.sha256(p.read_bytes()).hexdigest()
    with pytest.raises(InputError, match="has more than 4999 rows"):
        read_predictions(p, max_rows=4999)
