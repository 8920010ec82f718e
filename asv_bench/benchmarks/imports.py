"""`odms-data import recording`: a folder of PNG masks and their camera positions decoded into a
store with the robot protocol's windows (one decoding process)."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np

from ._cli import InFolder, odms_data

FRAMES = 120
WINDOWS = "10,15,20,25,30"


class ImportRecording(InFolder):
    timeout = 300

    def setup_cache(self) -> None:
        """A disc that shrinks as the camera moves away: frame i at z = i cm, depth 0.5 + z."""
        folder = Path("masks")
        folder.mkdir(exist_ok=True)
        rows = ["frame,z,depth"]
        for i in range(FRAMES):
            z = i / 100
            mask = np.zeros((480, 640), np.uint8)
            cv2.circle(mask, (320, 240), round(60 / (0.5 + z)), 255, -1)
            cv2.imwrite(str(folder / f"{i:04d}.png"), mask)
            rows.append(f"{i:04d}.png,{z},{0.5 + z}")
        Path("positions.csv").write_text("\n".join(rows) + "\n")

    def time_import_recording(self) -> None:
        odms_data(
            "import", "recording", str(Path("masks").resolve()), "--positions",
            str(Path("positions.csv").resolve()), "--windows", WINDOWS, "-o", self.out("recording.zarr"),
            "--workers", "1",
        )
