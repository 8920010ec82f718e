"""Ctrl-C (or a SIGTERM to the whole process group, as a job scheduler sends) at any moment of a
command that uses workers prints one line: a real signal, sent to the whole process group (the
command, its fork server and workers), of a real `generate`."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path

import psutil
import pytest

INTERRUPTED = "odms-data: interrupted ({}); nothing was left half-written"


def _wait_for(condition: Callable[[], bool], p: subprocess.Popen) -> None:
    while not condition():
        assert p.poll() is None, "the command ended before the moment to interrupt it"
        time.sleep(0.005)


def _fork_server(p: subprocess.Popen, loading_kernels: bool) -> bool:
    """Whether the command's fork server has started (and, with `loading_kernels`, is loading Numba)."""
    try:
        for child in psutil.Process(p.pid).children():
            if "forkserver" in " ".join(child.cmdline()):
                return not loading_kernels or any("llvmlite" in m.path for m in child.memory_maps())
    except psutil.Error:  # a process that has just ended
        pass
    return False


@pytest.mark.parametrize("signum", [signal.SIGINT, signal.SIGTERM], ids=["SIGINT", "SIGTERM"])
@pytest.mark.parametrize("moment", ["store begun", "fork server starts", "kernels load", "mid-run"])
def test_stop_signal_prints_one_line(tmp_path, moment, signum):
    out = tmp_path / "out.zarr"
    p = subprocess.Popen(
        [str(Path(sys.executable).with_name("odms-data")), "generate", "-n", "3000", "--workers", "2",
         "--examples-per-shard", "20", "-o", str(out)],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True,
        # the signal's default disposition, as in a terminal, also where these tests run in the background
        preexec_fn=lambda: signal.signal(signum, signal.SIG_DFL))
    if moment == "store begun":  # before any worker: the store's partial folder is there
        _wait_for(lambda: any(tmp_path.iterdir()), p)
    elif moment == "fork server starts":
        _wait_for(lambda: _fork_server(p, False), p)
    elif moment == "kernels load":  # the fork server imports the renderer and loads its kernels
        _wait_for(lambda: _fork_server(p, True), p)
    else:  # examples are coming back from the workers
        assert p.stderr is not None
        first = p.stderr.readline()
        assert first.startswith("generating "), first
    os.killpg(p.pid, signum)
    _, err = p.communicate(timeout=120)
    lines = [line for line in err.splitlines() if not line.startswith("generating ")]
    assert p.returncode == 128 + signum and lines == [INTERRUPTED.format(signum.name)], err
    assert not any(tmp_path.iterdir())


FINALIZER_GETS_THE_SIGNAL = """
import os, signal, sys, time
from odms_data.interrupts import stops_interrupt

class Finalized:
    def __del__(self):  # the signal comes while the finalizer runs; Python swallows what it raises
        os.kill(os.getpid(), signal.SIGTERM)
        for _ in range(1000):
            pass

with stops_interrupt():
    try:
        Finalized()
        time.sleep(30)
        sys.exit("the stop was lost: the command ran on to its end")
    except KeyboardInterrupt as e:
        sys.exit(128 + e.signum)
"""


def test_stop_during_a_finalizer_is_not_lost():
    """A stop signal that arrives while a finalizer runs stops the command, without the traceback
    Python prints for an exception raised in a finalizer."""
    p = subprocess.run([sys.executable, "-c", FINALIZER_GETS_THE_SIGNAL], capture_output=True, text=True,
                       timeout=120)
    assert p.returncode == 128 + signal.SIGTERM and p.stderr == "", p.stderr


def test_a_stop_a_c_extension_returned_as_another_error_is_still_a_stop():
    """A stop whose handler ran inside a C extension can come back as the error that extension made
    of it (Numba's dispatcher: "SystemError: ... returned a result with an exception set", caused by
    the stop): the command says it was interrupted, not that it failed."""
    import click
    from click.testing import CliRunner

    from odms_data.cli import OdmsGroup
    from odms_data.errors import Interrupted
    from odms_data.interrupts import stop_signal

    stop = Interrupted(signal.SIGTERM)
    try:
        raise SystemError("<CPUDispatcher> returned a result with an exception set") from stop
    except SystemError as e:
        wrapped = e
    assert stop_signal(wrapped) == stop_signal(stop) == signal.SIGTERM
    assert stop_signal(ValueError("a failure")) is None

    @click.command()
    def interrupted_inside() -> None:
        raise wrapped

    class OneCommand(OdmsGroup):
        def get_command(self, ctx, name):
            return interrupted_inside if name == "run" else None

    r = CliRunner().invoke(OneCommand(name="odms-data"), ["run"])
    assert r.exit_code == 128 + signal.SIGTERM, r.output
    assert r.stderr.strip() == INTERRUPTED.format("SIGTERM")
