"""Run odms-data's commands in this process, as a user types them, and make the small stores
the benchmarks read. The command line is the interface every measured commit shares."""

from __future__ import annotations

import contextlib
import io

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
