"""Commands that read a store: validate, convert to the other backend, the VOS-DE baseline and
score, and reading every example through the NumPy loader. The stores are generated once
(setup_cache) into asv's working folder."""

from __future__ import annotations

from pathlib import Path

from ._cli import InFolder, make_store, odms_data

BACKENDS = {"zarr": "sim.zarr", "h5": "sim.h5"}
OTHER = {"zarr": "h5", "h5": "zarr"}


class _Stores(InFolder):
    params = list(BACKENDS)
    param_names = ["backend"]
    timeout = 300

    def setup_cache(self) -> None:
        for name in BACKENDS.values():
            make_store(name)
        odms_data("baseline", "vosde", "sim.zarr", "--data", "sim.zarr", "-o", "vosde.csv", "--overwrite")

    def setup(self, backend: str) -> None:
        super().setup()
        self.store = str(Path(BACKENDS[backend]).resolve())


class Validate(_Stores):
    def time_validate(self, backend: str) -> None:
        odms_data("validate", self.store)


class Convert(_Stores):
    def time_convert(self, backend: str) -> None:
        copy = self.out(f"copy.{OTHER[backend]}")
        odms_data("convert", self.store, copy, "--overwrite")


class Score(_Stores):
    def time_baseline_vosde(self, backend: str) -> None:
        output = self.out("vosde.csv")
        odms_data("baseline", "vosde", self.store, "--data", self.store, "-o", output, "--overwrite")

    def time_score(self, backend: str) -> None:
        odms_data("score", str(Path("vosde.csv").resolve()), "--data", self.store)


class Read(_Stores):
    def time_store_batches(self, backend: str) -> None:
        from odms_data.loaders import store_batches

        for _ in store_batches(self.store, 16):
            pass
