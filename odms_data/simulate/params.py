"""The generator's parameters and named presets: plain data (no numpy), so that the command line
can offer them without loading the renderer."""

from __future__ import annotations

import difflib
import math
from dataclasses import asdict, dataclass, fields, replace
from typing import Any

from ..errors import InputError

DEFAULT_EXAMPLES_PER_SHARD = 512  # examples per shard task of a generated store
# Recorded in every generated store (attribute generator.version; absent before version 2). 2:
# silhouettes without holes, every pixel the contour passes through (raster.py); the released
# generator's point spacing rule. 1: cv2.fillPoly of the contour, even-odd; Euclidean spacing.
GENERATOR_VERSION = 2
MAX_SIDE = 8192  # px, the largest image height or width
MAX_FRAMES = 2**40  # frames in one store
MAX_CURVE_POINTS = 100_000  # an outline's samples: its drawing takes over 2 KiB of memory each
MAX_EXAMPLE_BYTES = 2**30  # one example's bit-packed masks, held in memory while it is drawn

# name -> (kind, low, high): the allowed range of each parameter (of each item for tuples); a high
# of None is relative to the image (see _range_problem). The ranges keep a frame's drawing bounded:
# the object's box is at most 4 image sides or 1000 px (and MAX_SIDE), the Bezier handles at most
# 2 chords, the perturbation at most 100 px deep, a contour at most MAX_CURVE_POINTS points, one
# example's masks at most MAX_EXAMPLE_BYTES.
LIMITS: dict[str, tuple[type, float, float | None]] = {
    "n_obs": (int, 2, 1000),
    "d_min": (float, 0.0, 1e6), "d_max": (float, 0.0, 1e6), "dz_min": (float, 0.0, 1e6),
    "image_size": (int, 1, MAX_SIDE),
    "sizes": (int, 1, None),
    "n_points": (int, 3, 1000),
    "bezier_radius": (float, 0.0, 2.0),
    "bezier_rotation": (float, -1e6, 1e6),
    "perturb_std": (float, 0.0, 100.0),
    "min_spacing": (float, 0.0, 1.0),
    "spacing_tries": (int, 1, 10_000),
    "curve_samples": (int, 2, 10_000),
}
POSITIVE = ("d_min", "d_max", "dz_min")  # strictly above their low
LISTS = ("image_size", "sizes", "n_points", "bezier_radius", "bezier_rotation")


def _range_problem(name: str, value: Any, params: GeneratorParams) -> str | None:
    """What is wrong with `value` of parameter `name`, with the allowed range; None when nothing."""
    kind, low, high = LIMITS[name]
    if high is None:  # sizes: up to 4 sides of the image, or 1000 px (the paper's sizes on any image)
        valid = _range_problem("image_size", params.image_size, params) is None
        high = min(max(4 * max(params.image_size), 1000), MAX_SIDE) if valid else MAX_SIDE
    what = "whole number" if kind is int else "number"
    shown = list(value) if isinstance(value, tuple) else value
    allowed = f"{what}s" if name in LISTS else f"a {what}"
    allowed += f" {'>' if name in POSITIVE else '>='} {low:g} and <= {high:g}"
    if name in LISTS:
        if not isinstance(value, tuple) or not value or (name == "image_size" and len(value) != 2):
            shape = "[height, width]" if name == "image_size" else "a non-empty list"
            return f"{name} must be {shape} of {allowed}, got {shown!r}"
    for v in value if name in LISTS else (value,):
        right_kind = isinstance(v, int) if kind is int else isinstance(v, int | float)
        if (isinstance(v, bool) or not right_kind or not math.isfinite(v) or v < low or v > high
                or (v == low and name in POSITIVE)):
            return f"{name} must be {allowed}, got {shown!r}"
    return None


@dataclass(frozen=True)
class GeneratorParams:
    """Every knob of the generator; the defaults are the paper's `standard` preset."""

    n_obs: int = 10
    d_min: float = 0.1  # m, closest camera position; the contour is drawn at scale 1 here
    d_max: float = 0.7  # m, farthest camera position
    dz_min: float = 0.1  # m, least camera movement z_n - z_1
    image_size: tuple[int, int] = (480, 640)  # height, width
    sizes: tuple[int, ...] = (100, 200, 300, 400)  # s_p, px
    n_points: tuple[int, ...] = (3, 4, 5, 6, 7, 8, 9, 10)  # n_p
    bezier_radius: tuple[float, ...] = (0.01, 0.05, 0.2, 0.5)  # r_B
    bezier_rotation: tuple[float, ...] = (0.01, 0.05, 0.2)  # rho_B
    perturb_std: float = 0.0  # sigma of eq. 20; 0 disables perturbation
    min_spacing: float = 0.7  # consecutive contour points |dx + dy| >= min_spacing / n_p * s_p ...
    spacing_tries: int = 201  # ... in at most this many draws (the authors' released generator)
    curve_samples: int = 32  # points per Bezier segment

    def __post_init__(self) -> None:
        problems = [p for name in LIMITS if (p := _range_problem(name, getattr(self, name), self))]
        if not problems:
            H, W = self.image_size
            if self.n_obs * H * ((W + 7) // 8) > MAX_EXAMPLE_BYTES:
                problems.append(f"n_obs={self.n_obs} masks of {H}x{W} take "
                                f"{self.n_obs * H * ((W + 7) // 8) / 2**30:.1f} GiB per example, more than "
                                f"the {MAX_EXAMPLE_BYTES / 2**30:g} GiB allowed; use fewer or smaller masks")
            if self.curve_samples * max(self.n_points) > MAX_CURVE_POINTS:
                problems.append(f"curve_samples x the largest n_points must be <= {MAX_CURVE_POINTS}, got "
                                f"{self.curve_samples} x {max(self.n_points)}")
            if not self.d_min < self.d_max:
                problems.append(f"need d_min < d_max, got d_min={self.d_min}, d_max={self.d_max}")
            elif not self.dz_min <= self.d_max - self.d_min:
                problems.append(f"need dz_min <= d_max - d_min, got dz_min={self.dz_min}")
        if problems:
            raise InputError("generator parameters: " + "; ".join(problems))

    def to_json(self) -> dict[str, Any]:
        d = asdict(self)
        return {k: list(v) if isinstance(v, tuple) else v for k, v in d.items()}

    @classmethod
    def from_json(cls, d: dict[str, Any]) -> GeneratorParams:
        unknown = sorted(set(d) - set(parameter_names()))
        if unknown:
            names = [n + (f" (did you mean {c}?)" if (c := closest_parameter(n)) else "") for n in unknown]
            raise InputError(f"generator parameters: unknown name(s) {', '.join(names)}")
        values: dict[str, Any] = {k: tuple(v) if isinstance(v, list) else v for k, v in d.items()}
        try:
            return cls(**values)
        except TypeError as e:
            raise InputError(f"generator parameters: a value has the wrong type ({e})") from None


def parameter_names() -> list[str]:
    return [f.name for f in fields(GeneratorParams)]


def closest_parameter(name: str) -> str | None:
    """The generator parameter a mistyped `name` most likely means (dmax: d_max), if any."""
    close = difflib.get_close_matches(name, parameter_names(), n=1, cutoff=0.6)
    return close[0] if close else None


PRESETS: dict[str, GeneratorParams] = {
    "standard": GeneratorParams(),
    "perturb": GeneratorParams(perturb_std=1.0),
}


def preset(name: str, **overrides: Any) -> GeneratorParams:
    """A named preset with some parameters replaced."""
    if name not in PRESETS:
        raise InputError(f"unknown preset '{name}'; choose from {', '.join(PRESETS)}")
    return replace(PRESETS[name], **overrides)


def merged_params(name: str, overrides: dict[str, Any]) -> GeneratorParams:
    """Preset `name`'s parameters with `overrides` (names and JSON values: a manifest's or the
    user's) merged in, checked."""
    return GeneratorParams.from_json({**preset(name).to_json(), **overrides})
