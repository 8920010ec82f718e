"""Time estimates: not from the start-up before the first item, and training's with its validations;
the notice while the kernels compile on first use."""

from __future__ import annotations

import os
import subprocess
import sys

import pytest

from odms_data.cli.progress import _Lines


class Clock:
    """A clock the test moves: the seconds a line reports are then known exactly."""

    def __init__(self) -> None:
        self.now = 0.0

    def __call__(self) -> float:
        return self.now


def test_the_first_report_gives_no_estimate_and_later_ones_the_rate_since(capsys):
    clock = Clock()
    lines = _Lines(100, "generating x.zarr", clock)
    clock.now = 30.0  # workers started and kernels loaded: 30 s before the first 10 items
    lines.update(10)
    clock.now = 40.0  # then an item a second
    lines.update(10)
    clock.now = 50.0
    lines.update(10)
    assert lines.line() == "generating x.zarr: 30/100 (30%), 0:50 elapsed, about 1:10 left"
    first, second, third = capsys.readouterr().err.splitlines()
    assert first == "generating x.zarr: 10/100 (10%), 0:30 elapsed"  # not "about 4:30 left"
    assert second == "generating x.zarr: 20/100 (20%), 0:40 elapsed, about 1:20 left"


def test_training_time_left_counts_the_validations_to_come():
    from odms_data.network.training import Status

    # 20 of 100 iterations: the first took 5 s (the loader starting), the next 19 took 19 s, and two
    # validations (at 10 and 20) took 3 s each
    s = Status(20, 100, 8, 0, 5 + 19 + 6, val_every=10, first_seconds=5, val_seconds=6, validations=2)
    assert s.seconds_left == pytest.approx(80 * 1 + 8 * 3)
    assert Status(1, 100, 8, 0, 5.0, val_every=10, first_seconds=5).seconds_left is None  # nothing measured
    s = Status(95, 100, 8, 0, 0, val_every=10, first_seconds=0, val_seconds=3, validations=1)
    s.seconds = 94 + 3
    assert s.seconds_left == pytest.approx(5 * 1 + 1 * 3)  # the last iteration validates too
    done = Status(100, 100, 8, 0, 103, val_every=10, first_seconds=1, val_seconds=3, validations=1)
    assert done.seconds_left == pytest.approx(0)


def test_first_use_says_the_kernels_compile_and_only_then(tmp_path):
    """The first generate in a fresh cache compiles the kernels (seconds of silence otherwise) and
    says so in one line; a bad argument still gets its one line alone, and a later run no notice."""
    env = {**os.environ, "XDG_CACHE_HOME": str(tmp_path / "cache")}
    env.pop("NUMBA_CACHE_DIR", None)

    def generate(*args: str) -> subprocess.CompletedProcess:
        return subprocess.run([sys.executable, "-m", "odms_data.cli", "generate", "-n", "2", *args],
                              cwd=tmp_path, env=env, capture_output=True, text=True)

    bad = generate("--param", "d_max=abc", "-o", "bad.zarr")
    assert bad.returncode == 2 and len(bad.stderr.splitlines()) == 1, bad.stderr
    first = generate("-o", "a.zarr")
    assert first.returncode == 0, first.stderr
    assert first.stderr.splitlines()[0] == ("odms-data: compiling the drawing kernels for this machine, once "
                                            "(about 10 s; later runs load them)")
    again = generate("-o", "b.zarr")
    assert again.returncode == 0 and "compiling" not in again.stderr, again.stderr
