"""Run odms-data's commands in this process, as a user types them, and make the small stores
the benchmarks read. The command line is the interface every measured commit shares."""

from __future__ import annotations

import contextlib
import io
import tempfile
from pathlib import Path

from odms_data.cli import main

EXAMPLES = 64
"""Examples (480x640, n = 10) in each store the benchmarks make."""


def odms_data(*args: str) -> None:
    """`odms-data ARGS`, its output discarded; raises when the command fails."""
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
        code = main(list(args), standalone_mode=False)
    if code not in (None, 0):
        raise RuntimeError(f"odms-data {' '.join(args)} exited with {code}")


def make_store(path: str, count: int = EXAMPLES) -> str:
    """Generate a store of `count` standard examples at `path` (.zarr or .h5) in one process."""
    odms_data("generate", "-n", str(count), "--seed", "0", "--workers", "1", "-o", path, "--overwrite")
    return path


class InFolder:
    """A fresh temporary folder for each timed run, removed after it: `self.out(name)` is a path
    in it. asv passes a benchmark's parameters to setup and teardown."""

    def setup(self, *params: object) -> None:
        self.folder = tempfile.TemporaryDirectory()

    def teardown(self, *params: object) -> None:
        self.folder.cleanup()

    def out(self, name: str) -> str:
        return str(Path(self.folder.name) / name)
