"""The generator's parameters and named presets: plain data (no numpy), so that the command line
can offer them without loading the renderer."""

from __future__ import annotations

from dataclasses import asdict, dataclass, fields, replace
from typing import Any

from ..errors import InputError

DEFAULT_EXAMPLES_PER_SHARD = 128  # examples per shard task of a generated store
# Recorded in every generated store (attribute generator.version; absent before version 2). 2:
# silhouettes without holes, every pixel the contour passes through (raster.py); the released
# generator's point spacing rule. 1: cv2.fillPoly of the contour, even-odd; Euclidean spacing.
GENERATOR_VERSION = 2


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
        problems = []
        if self.n_obs < 2:
            problems.append(f"n_obs must be at least 2, got {self.n_obs}")
        if not 0 < self.d_min < self.d_max:
            problems.append(f"need 0 < d_min < d_max, got d_min={self.d_min}, d_max={self.d_max}")
        elif not 0 < self.dz_min <= self.d_max - self.d_min:
            problems.append(f"need 0 < dz_min <= d_max - d_min, got dz_min={self.dz_min}")
        if len(self.image_size) != 2 or min(self.image_size) < 1:
            problems.append(f"image_size must be (height, width) >= 1, got {self.image_size}")
        for name in ("sizes", "n_points", "bezier_radius", "bezier_rotation"):
            if not getattr(self, name):
                problems.append(f"{name} must not be empty")
        if any(s <= 0 for s in self.sizes) or any(p < 3 for p in self.n_points):
            problems.append("sizes must be positive and n_points at least 3")
        if self.perturb_std < 0 or self.curve_samples < 2:
            problems.append("perturb_std must be >= 0 and curve_samples >= 2")
        if self.min_spacing < 0 or self.spacing_tries < 1:
            problems.append("min_spacing must be >= 0 and spacing_tries >= 1")
        if problems:
            raise InputError("generator parameters: " + "; ".join(problems))

    def to_json(self) -> dict[str, Any]:
        d = asdict(self)
        return {k: list(v) if isinstance(v, tuple) else v for k, v in d.items()}

    @classmethod
    def from_json(cls, d: dict[str, Any]) -> GeneratorParams:
        known = {f.name for f in fields(cls)}
        unknown = sorted(set(d) - known)
        if unknown:
            raise InputError(f"generator parameters: unknown name(s) {', '.join(unknown)}")
        values: dict[str, Any] = {k: tuple(v) if isinstance(v, list) else v for k, v in d.items()}
        try:
            return cls(**values)
        except TypeError as e:
            raise InputError(f"generator parameters: a value has the wrong type ({e})") from None


PRESETS: dict[str, GeneratorParams] = {
    "standard": GeneratorParams(),
    "perturb": GeneratorParams(perturb_std=1.0),
}


def preset(name: str, **overrides: Any) -> GeneratorParams:
    """A named preset with some parameters replaced."""
    if name not in PRESETS:
        raise InputError(f"unknown preset '{name}'; choose from {', '.join(PRESETS)}")
    return replace(PRESETS[name], **overrides)
