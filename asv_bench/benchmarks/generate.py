"""`odms-data generate` into a Zarr and an HDF5 store (480x640, n = 10, one process)."""

from __future__ import annotations

from ._cli import InFolder, make_store


class Generate(InFolder):
    params = ["zarr", "h5"]
    param_names = ["backend"]
    timeout = 300

    def time_generate(self, backend: str) -> None:
        make_store(self.out(f"sim.{backend}"))

    def peakmem_generate(self, backend: str) -> None:
        make_store(self.out(f"sim.{backend}"))
