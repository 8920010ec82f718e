"""Stores of boxes (ODMD's kind): `odms-data generate --boxes` (one process), and `score` of a
predictions file as big as the official ODMS test (Box_LS's, made once in setup_cache)."""

from __future__ import annotations

from pathlib import Path

from ._cli import InFolder, odms_data

COUNT = 15_650
"""Examples in the store of boxes: the official ODMS test's size."""


class Boxes(InFolder):
    timeout = 300

    def setup_cache(self) -> None:
        odms_data("generate", "--boxes", "odmd", "-n", str(COUNT), "--seed", "0", "-o", "boxes.zarr",
                  "--overwrite")
        odms_data("baseline", "box-ls", "boxes.zarr", "-o", "box-ls.csv", "--overwrite")

    def time_generate_boxes(self) -> None:
        odms_data("generate", "--boxes", "odmd", "-n", str(COUNT), "--seed", "0",
                  "-o", self.out("boxes.zarr"))

    def time_score_big_file(self) -> None:
        odms_data("score", str(Path("box-ls.csv").resolve()), "--data", str(Path("boxes.zarr").resolve()))
