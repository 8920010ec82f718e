"""`odms-data generate` into a Zarr and an HDF5 store (480x640, n = 10, one process)."""

from __future__ import annotations

import tempfile
from pathlib import Path

from ._cli import make_store


class Generate:
    params = ["zarr", "h5"]
    param_names = ["backend"]
    timeout = 300

    def setup(self, backend: str) -> None:
        self.folder = tempfile.TemporaryDirectory()
        self.output = str(Path(self.folder.name) / f"sim.{backend}")

    def teardown(self, backend: str) -> None:
        self.folder.cleanup()

    def time_generate(self, backend: str) -> None:
        make_store(self.output)

    def peakmem_generate(self, backend: str) -> None:
        make_store(self.output)
