"""The rules every output follows (odms_data.outputs), on their own."""

from __future__ import annotations

import hashlib
import os
import signal

import pytest

from odms_data.errors import InputError, Interrupted, OutputExistsError, WriteError
from odms_data.evaluation.predictions import read_predictions
from odms_data.interrupts import stop_requested, uninterrupted
from odms_data.outputs import atomic_file, check_replaceable, replaced_via_partial, write_text


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
    with pytest.raises(OutputExistsError, match="already exists; pass --overwrite"):
        check_replaceable(tmp_path / "a.csv", False, option="-o")
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


def test_the_predictions_hash_is_the_files(tmp_path):
    p = tmp_path / "p.csv"
    p.write_text("split,example_id,d1\n" + "".join(f"s,s/{i},{i}.5\n" for i in range(5000)))
    assert read_predictions(p).sha256 == hashlib.sha256(p.read_bytes()).hexdigest()
    with pytest.raises(InputError, match="has more than 4999 rows"):
        read_predictions(p, max_rows=4999)
