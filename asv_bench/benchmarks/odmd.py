"""ODMD's own files, read through the restricted reader: `odms-data import odmd` of its 16 pickled
sets, and `predict --model dbox --checkpoint` with its pretrained DBox on odms-detect-normal-val.
They come from shared/odmd beside the repository ($ODMS_SHARED/odmd); skipped without it."""

from __future__ import annotations

import os
from pathlib import Path

from ._cli import InFolder, odms_data

ODMD = Path(os.environ.get("ODMS_SHARED", Path(__file__).resolve().parents[3] / "shared")) / "odmd"
DBOX = ODMD / "model" / "DBox_pretrained_paper.pt"
STORE = "odms-detect-normal-val"


class Odmd(InFolder):
    timeout = 300

    def setup_cache(self) -> None:
        if DBOX.is_file():
            odms_data("import", "odmd", str(ODMD / "data"), "--set", STORE, "-o", "odmd", "--overwrite")

    def setup(self) -> None:
        super().setup()  # made first: asv calls teardown after a skip too
        if not DBOX.is_file():
            raise NotImplementedError(f"ODMD's sets and DBox are not in {ODMD}")

    def time_import_odmd(self) -> None:
        odms_data("import", "odmd", str(ODMD / "data"), "-o", self.out("stores"))

    def time_predict_dbox(self) -> None:
        store, output = str(Path(f"odmd/{STORE}.zarr").resolve()), self.out("dbox.csv")
        odms_data("predict", "--model", "dbox", "--checkpoint", str(DBOX), "--data", store, "-o", output,
                  "--workers", "0", "--device", "cpu")
