"""The SYNTHIA importer's choices, apart from the importer so that the command line can show
them cheaply: the classes and cameras SYNTHIA-SEQS has, how to read its camera files, and the
rules that select the examples. Sources and the reasons for each default: schemas/SYNTHIA.md.
"""

from __future__ import annotations

from dataclasses import dataclass

from ..errors import InputError

CLASS_IDS = {"car": 8, "pedestrian": 10, "bicycle": 11}  # SYNTHIA's class table
CLASS_NAMES = {v: k for k, v in CLASS_IDS.items()}
MAX_CLASS = 1 << 16  # label images are 16-bit: class ids are below this
CAMERAS = tuple(f"Stereo_{s}/Omni_{o}" for s in ("Left", "Right") for o in "FBLR")


@dataclass(frozen=True)
class PoseConvention:
    """How to read a CameraParams file."""

    order: str = "column-major"  # of the 16 numbers; or "row-major"
    direction: str = "camera-to-world"  # or "world-to-camera"
    forward: str = "-z"  # the optical axis among the camera's own axes; or "+z"


@dataclass(frozen=True)
class Selection:
    """The protocol's rules; the defaults are the paper's."""

    classes: tuple[int, ...] = tuple(CLASS_IDS.values())
    frames: tuple[int, ...] = (10,)  # frames per example; several give several windows per closest frame
    stride: int = 1  # a window starts every `stride` frames of its track
    min_area: int = 1  # pixels of the mask at the closest frame
    border: bool = True  # may the instance touch the image border in a frame of the window
    occluded: bool = True  # may it be partly hidden in a frame of the window
    move: tuple[float, float] = (4.15, 68.5)  # m, camera movement z_n - z_1 (the paper: 4.2 to 68)
    d1: tuple[float, float] = (1.45, 62.5)  # m (the paper: 1.5 to 62)
    max_gap: int = 5  # frames an instance may be absent inside its track

    def check(self) -> None:
        if not self.classes:
            raise InputError("classes: give at least one class", option="classes")
        if not self.frames or min(self.frames) < 2:
            raise InputError("frames: an example needs at least 2 frames", option="frames")
        if self.stride < 1 or self.min_area < 1 or self.max_gap < 0:
            raise InputError("stride and min_area must be at least 1, max_gap at least 0")
        for option, (lo, hi) in (("move", self.move), ("d1", self.d1)):
            if not 0 <= lo < hi:
                raise InputError(f"{option} {lo} {hi}: expected 0 <= MIN < MAX (metres)", option=option)


SYNTHIA_POSES = PoseConvention()
PAPER_SELECTION = Selection()


def parse_classes(text: str) -> tuple[int, ...]:
    """'car,pedestrian' or SYNTHIA class ids ('8,10') into class ids."""
    out = []
    for t in (t.strip() for t in text.split(",")):
        if t in CLASS_IDS:
            out.append(CLASS_IDS[t])
        elif t.isascii() and t.isdigit() and int(t) < MAX_CLASS:
            out.append(int(t))
        else:
            raise InputError(f"classes '{t}': not a class; use {', '.join(CLASS_IDS)} or SYNTHIA class ids "
                             f"(0 to {MAX_CLASS - 1})", option="classes")
    return tuple(dict.fromkeys(out))
