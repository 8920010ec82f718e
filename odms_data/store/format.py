"""The on-disk format: array names, dtypes and the store attributes (see schemas/FORMAT.md)."""

from __future__ import annotations

import json
from collections import Counter
from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from functools import cache
from typing import Any

import numpy as np

from .._version import __version__
from ..errors import StoreError
from ..resources import resource_dir
from .declared import storage_problems
from .masks import packed_width

FORMAT_VERSION = 1
ATTRS_KEY = "odms"
UNITS = {"z": "m", "depth": "m", "d1": "m", "area": "px", "bbox": "px"}
Z_ODDITY = "z-not-increasing"  # the oddity kind that excuses z not increasing (FORMAT.md)

# name -> dtype; per-frame arrays have F rows, per-example arrays E rows.
FRAME_ARRAYS = {
    "masks": np.uint8,  # (F, H, ceil(W/8)) bit-packed, MSB first
    "z": np.float64,  # (F,) camera position on the optical axis, m
    "depth": np.float64,  # (F,) object depth, m; NaN where unknown
    "area": np.int32,  # (F,) object pixels
    "largest_area": np.int32,  # (F,) pixels of the largest 8-connected region
    "bbox": np.int32,  # (F, 4) x0, y0, x1, y1 half-open; zeros when empty
}
EXAMPLE_ARRAYS = {
    "frame_index": np.int64,  # (E, N) frame rows, z ascending, padded with -1 at the end
    "d1": np.float64,  # (E,) depth at the closest frame, m; NaN when unlabelled
    "example_id": np.uint8,  # (E, L) UTF-8, NUL padded
    "source": np.uint8,  # (E, L) UTF-8, NUL padded
}


@dataclass
class StoreAttrs:
    """The root attribute `odms` of a store."""

    split: str
    domain: str
    image_size: tuple[int, int]
    counts: dict[str, int]
    generator: dict[str, Any] | None = None
    source: str | None = None
    oddities: list[dict[str, str]] = field(default_factory=list)
    digest: str = ""
    complete: bool = False
    format_version: int = FORMAT_VERSION
    units: dict[str, str] = field(default_factory=lambda: dict(UNITS))
    created_by: str = f"odms-data {__version__}"

    @property
    def generator_version(self) -> int | None:
        """The version of the generator that made a generated store (1 when not recorded)."""
        return None if self.generator is None else self.generator.get("version", 1)

    def to_json(self) -> dict[str, Any]:
        d = asdict(self)
        d["image_size"] = list(self.image_size)
        return d

    @classmethod
    def from_json(cls, d: dict[str, Any], where: str) -> StoreAttrs:
        """Parse and check the attribute against schemas/store-attributes.schema.json."""
        problems = attribute_problems(d)
        if problems:
            raise StoreError(f"{where}: store attributes are invalid: {problems[0]}")
        d = dict(d)
        d["image_size"] = tuple(d["image_size"])
        return cls(**d)


@cache
def _attrs_validator():
    import jsonschema

    schema = json.loads((resource_dir("schemas") / "store-attributes.schema.json").read_text())
    return jsonschema.Draft202012Validator(schema)


def attribute_problems(d: Any) -> list[str]:
    """Every way `d` breaks the attribute schema, one line each ('at PATH: message')."""
    out = []
    for e in sorted(_attrs_validator().iter_errors(d), key=lambda e: list(e.path)):
        path = "/".join(str(p) for p in e.path) or "(root)"
        out.append(f"at {path}: {e.message}")
    return out


def layout_problems(backend: Any, raw: dict[str, Any]) -> list[str]:
    """Arrays whose shape or dtype disagrees with the (schema-valid) attributes `raw`."""
    F, E = raw["counts"]["frames"], raw["counts"]["examples"]
    H, W = raw["image_size"]
    expected = {
        "masks": (F, H, packed_width(W)), "z": (F,), "depth": (F,), "area": (F,),
        "largest_area": (F,), "bbox": (F, 4), "d1": (E,),
    }
    problems = []
    for name, dtype in {**FRAME_ARRAYS, **EXAMPLE_ARRAYS}.items():
        arr = backend.array(name)
        shape = tuple(arr.shape)
        if name in expected and shape != expected[name]:
            problems.append(f"array '{name}' has shape {shape}, expected {expected[name]}")
        elif name not in expected and (len(shape) != 2 or shape[0] != E or shape[1] < 1):
            problems.append(f"array '{name}' has shape {shape}, expected ({E}, width >= 1)")
        if np.dtype(arr.dtype) != np.dtype(dtype):
            problems.append(f"array '{name}' has dtype {arr.dtype}, expected {np.dtype(dtype)}")
    return problems or storage_problems(backend, {**FRAME_ARRAYS, **EXAMPLE_ARRAYS})


def encode_strings(values: list[str]) -> np.ndarray:
    """(E, L) uint8 NUL-padded UTF-8 matrix of `values` (L >= 1)."""
    raw = [v.encode() for v in values]
    width = max([1, *map(len, raw)])
    out = np.zeros((len(raw), width), np.uint8)
    for i, b in enumerate(raw):
        out[i, : len(b)] = np.frombuffer(b, np.uint8)
    return out


def decode_strings(matrix: np.ndarray) -> list[str]:
    """Inverse of `encode_strings`."""
    return [bytes(row).rstrip(b"\0").decode() for row in np.asarray(matrix, np.uint8)]


# --- what the arrays may hold (schemas/FORMAT.md, "What a store may not hold") ---------------
# Each function returns one line per broken rule, naming the first offenders; `name(i)` names
# example row i (its id, where the ids are readable). The reader raises the first line when it
# reads the array; `validate` reports them all.

Name = Callable[[int], str]


def _first(values: Any, k: int = 5) -> str:
    values = [int(v) for v in values]
    return ", ".join(map(str, values[:k])) + (", ..." if len(values) > k else "")


def frame_index_problems(fi: np.ndarray, n_frames: int, name: Name) -> list[str]:
    """Rows of frames 0..F-1, -1 only as padding at the end, at least 2 frames per example."""
    if fi.size and (fi.min() < -1 or fi.max() >= n_frames):
        rows = np.nonzero(((fi < -1) | (fi >= n_frames)).any(axis=1))[0]
        row = fi[rows[0]]
        value = int(row.max()) if row.max() >= n_frames else int(row.min())
        return [f"frame_index of example {name(int(rows[0]))} holds {value}, outside the frames "
                f"0..{n_frames - 1} (and -1 for padding)"]
    problems = []
    padded = fi < 0
    inside = np.nonzero((padded[:, :-1] & ~padded[:, 1:]).any(axis=1))[0]
    if len(inside):
        problems.append(f"example {name(int(inside[0]))}: -1 padding is followed by a frame index")
    n_obs = (~padded).sum(axis=1)
    short = np.nonzero(n_obs < 2)[0]
    if len(short):
        problems.append(f"example {name(int(short[0]))} has {int(n_obs[short[0]])} frame(s), at least 2 "
                        f"are needed ({len(short)} such example(s))")
    return problems


def z_problems(z: np.ndarray) -> list[str]:
    """Camera positions are finite."""
    bad = np.nonzero(~np.isfinite(z))[0]
    return [f"z is not finite at frame(s) {_first(bad)}"] if len(bad) else []


def depth_problems(depth: np.ndarray) -> list[str]:
    """Depths are positive and finite where known (NaN where unknown)."""
    with np.errstate(invalid="ignore"):
        bad = np.nonzero(~np.isnan(depth) & ~(np.isfinite(depth) & (depth > 0)))[0]
    return [f"depth is not a positive distance (nor NaN) at frame(s) {_first(bad)}"] if len(bad) else []


def d1_problems(d1: np.ndarray, labelled: int, name: Name) -> list[str]:
    """Labels are positive and finite where known (NaN for unlabelled examples), and `labelled`
    (counts.labelled) of them are known."""
    problems = []
    with np.errstate(invalid="ignore"):
        bad = np.nonzero(~np.isnan(d1) & ~(np.isfinite(d1) & (d1 > 0)))[0]
    if len(bad):
        problems.append(f"d1 of example {name(int(bad[0]))} is {d1[bad[0]]}, not a positive depth "
                        f"({len(bad)} such example(s))")
    known = int((~np.isnan(d1)).sum())
    if known != labelled:
        problems.append(f"counts.labelled is {labelled}, but {known} examples have d1")
    return problems


def id_problems(ids: list[str], split: str) -> list[str]:
    """Ids are non-empty, unique and start with '<split>/'."""
    problems = []
    if any(not x for x in ids):
        problems.append(f"example row {ids.index('')} has an empty id")
    foreign = [x for x in ids if x and not x.startswith(split + "/")]
    if foreign:
        problems.append(f"example id {foreign[0]!r} does not start with its split '{split}/' "
                        f"({len(foreign)} such id(s))")
    if len(set(ids)) != len(ids):
        counts = Counter(ids)
        dup = next(x for x in ids if counts[x] > 1)
        problems.append(f"example id {dup!r} appears {counts[dup]} times")
    return problems


def stats_problems(
    area: np.ndarray, largest: np.ndarray, bbox: np.ndarray, height: int, width: int
) -> list[str]:
    """The statistics lie in the image: 0 <= largest_area <= area <= H*W, boxes inside the image."""
    bad = np.nonzero((largest < 0) | (largest > area) | (area > height * width))[0]
    problems = [f"area/largest_area are impossible at frame(s) {_first(bad)}"] if len(bad) else []
    x0, y0, x1, y1 = bbox.T if bbox.size else (np.zeros(0),) * 4
    out = np.nonzero((x0 < 0) | (y0 < 0) | (x1 > width) | (y1 > height) | (x0 > x1) | (y0 > y1))[0]
    if len(out):
        problems.append(f"bbox lies outside the image at frame(s) {_first(out)}")
    return problems
