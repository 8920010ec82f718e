"""The on-disk format: array names, dtypes and the store attributes (see schemas/FORMAT.md)."""

from __future__ import annotations

import json
from collections import Counter
from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from functools import cache
from pathlib import Path
from typing import Any

import numpy as np

from .._version import __version__
from ..errors import StoreError
from ..resources import resource_dir
from .masks import packed_width
from .oddity import Oddity

FORMAT_VERSION = 1  # the version of a store of masks; a store of boxes is version 2 (VERSIONS)
KINDS = ("masks", "boxes")  # what a store's examples are made of (attribute `kind`; masks when absent)
VERSIONS = {"masks": 1, "boxes": 2}  # the format version that introduced each kind, which its stores carry
ATTRS_KEY = "odms"
UNITS = {"z": "m", "depth": "m", "d1": "m", "area": "px", "bbox": "px"}
Z_ODDITY = "z-not-increasing"  # the oddity kind that excuses z not increasing (FORMAT.md)


@dataclass(frozen=True)
class Array:
    """One array of a store. Its rows are the store's frames (F) or examples (E); `trailing` is
    the rest of its shape, each a number or the name of a size (see FREE_SIZES)."""

    name: str
    dtype: type
    per: str  # "frame" or "example"
    trailing: tuple[int | str, ...] = ()
    hub: tuple[str, str] | None = None  # the Hub column: (Croissant data type, description)
    hub_by_kind: tuple[tuple[str, str], ...] = ()  # (kind, description) where the column means otherwise
    sharded: bool = False  # written whole shards at a time (masks), chunked inside each shard
    text: bool = False  # NUL-padded UTF-8 strings, one per row (`encode_strings`)
    pad: int = 0  # what fills a row's columns beyond those written
    kinds: tuple[str, ...] = KINDS  # the kinds of store that hold it

    def hub_of(self, kind: str) -> tuple[str, str] | None:
        """The Hub column of this array in a store of `kind`: (Croissant data type, description)."""
        if self.hub is None:
            return None
        return self.hub[0], dict(self.hub_by_kind).get(kind, self.hub[1])


# The sizes `trailing` may name: "height" and "packed_width" follow from the image size in the
# attributes; the free ones are the writer's choice and need only be at least 1.
FREE_SIZES = ("max_obs", "id_width", "source_width")

# Every array of a store, in the order they are created and checked. Adding an array is one row
# here and the code that computes it (which hands it to StoreWriter.write_rows).
ARRAYS = {a.name: a for a in (
    Array("masks", np.uint8, "frame", ("height", "packed_width"), sharded=True, kinds=("masks",),
          hub=("sc:Text", "each observation's binary mask, bit-packed: height rows of ceil(width / 8) "
               "bytes, most significant bit first (numpy.packbits(mask, axis=-1))")),
    Array("z", np.float64, "frame", kinds=("masks",),  # camera position on the optical axis, m
          hub=("sc:Float", "camera position (m) of each observation, ascending")),
    Array("depth", np.float64, "frame",  # object depth, m; NaN where unknown
          hub=("sc:Float", "object depth (m) at each observation; NaN where unknown")),
    Array("area", np.int32, "frame", hub=("sc:Integer", "object pixels of each mask"),  # object pixels
          kinds=("masks",)),
    Array("largest_area", np.int32, "frame", kinds=("masks",)),  # pixels of the largest 8-connected region
    Array("bbox", np.int32, "frame", (4,), kinds=("masks",)),  # x0, y0, x1, y1 half-open; zeros when empty
    Array("box", np.float64, "frame", (4,), kinds=("boxes",),  # x_c, y_c, w, h normalised; zeros: missed
          hub=("sc:Float", "the object's detection box of each observation, [x_c, y_c, w, h] divided by "
               "the image width (x_c, w) and height (y_c, h); all 0 for a missed detection")),
    Array("move", np.float64, "frame", (3,), kinds=("boxes",),  # to the example's last frame, m
          hub=("sc:Float", "the object's displacement (m) in x, y, z from each observation to its "
               "example's last one, in the camera's axes (ODMD's camera movement); 0 at the last")),
    Array("frame_index", np.int64, "example", ("max_obs",), pad=-1),  # frame rows, z ascending, -1 after
    Array("d1", np.float64, "example",  # depth at the closest frame, m; NaN when unlabelled
          hub=("sc:Float", "label: depth (m) at the closest observation, z_1; NaN when unlabelled"),
          hub_by_kind=(("boxes", "label: depth (m) at the last observation; NaN when unlabelled"),)),
    Array("example_id", np.uint8, "example", ("id_width",), text=True,
          hub=("sc:Text", "the example's id, <split>/<name>")),
    Array("source", np.uint8, "example", ("source_width",), text=True,
          hub=("sc:Text", "where the example came from")),
)}


def arrays_of(kind: str) -> dict[str, Array]:
    """The arrays a store of `kind` holds, in table order."""
    return {name: a for name, a in ARRAYS.items() if kind in a.kinds}


def kind_of(raw: dict[str, Any]) -> str:
    """The kind of a store from its (schema-valid) attributes: masks when they name none."""
    return str(raw.get("kind", "masks"))


def arrays_per(per: str, kind: str = "masks") -> list[Array]:
    """The arrays of a store of `kind` with a row per frame (`per` "frame") or per example
    ("example"), in table order."""
    return [a for a in arrays_of(kind).values() if a.per == per]


def shape_of(a: Array, rows: int, sizes: dict[str, int]) -> tuple[int, ...]:
    """The shape of array `a` with `rows` rows, its named sizes taken from `sizes`."""
    return (rows, *(sizes[d] if isinstance(d, str) else d for d in a.trailing))


# Each backend's file-name suffixes; the first is the one odms-data gives a store it names.
SUFFIXES = {"zarr": (".zarr",), "hdf5": (".h5", ".hdf5", ".hdf")}


def format_of_name(path: str | Path) -> str | None:
    """The backend the name of `path` says ('zarr' or 'hdf5'), or None when its suffix says none."""
    suffix = Path(path).suffix.lower()
    return next((fmt for fmt, suffixes in SUFFIXES.items() if suffix in suffixes), None)


def store_path(folder: str | Path, split: str, fmt: str) -> Path:
    """Where odms-data puts the store of `split` in `folder` in backend `fmt`."""
    return Path(folder) / f"{split}{SUFFIXES[fmt][0]}"


@dataclass
class StoreAttrs:
    """The root attribute `odms` of a store."""

    split: str
    domain: str
    image_size: tuple[int, int]
    counts: dict[str, int]
    generator: dict[str, Any] | None = None
    source: str | None = None
    oddities: list[Oddity] = field(default_factory=list)
    digest: str = ""
    complete: bool = False
    format_version: int = FORMAT_VERSION
    units: dict[str, str] = field(default_factory=lambda: dict(UNITS))
    created_by: str = f"odms-data {__version__}"
    kind: str = "masks"

    def __post_init__(self) -> None:
        if self.kind != "masks":  # a store of masks reads and writes as before the kinds
            self.format_version = VERSIONS[self.kind]

    @property
    def generator_version(self) -> int | None:
        """The version of the generator that made a generated store (1 when not recorded)."""
        return None if self.generator is None else self.generator.get("version", 1)

    def to_json(self) -> dict[str, Any]:
        d = asdict(self)
        d["image_size"] = list(self.image_size)
        d["oddities"] = [o.to_json() for o in self.oddities]
        if self.kind == "masks":
            del d["kind"]  # attributes of stores of masks stay as format version 1 wrote them
        return d

    @classmethod
    def from_json(cls, d: dict[str, Any], where: str) -> StoreAttrs:
        """Parse and check the attribute against schemas/store-attributes.schema.json."""
        problems = attribute_problems(d)
        if problems:
            raise StoreError(f"{where}: store attributes are invalid: {problems[0]}")
        d = dict(d)
        d["image_size"] = tuple(d["image_size"])
        d["oddities"] = [Oddity.from_json(o) for o in d.get("oddities", [])]
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
    rows = {"frame": raw["counts"]["frames"], "example": raw["counts"]["examples"]}
    H, W = raw["image_size"]
    sizes = {"height": H, "packed_width": packed_width(W), **dict.fromkeys(FREE_SIZES, -1)}  # -1: free
    problems = []
    for a in arrays_of(kind_of(raw)).values():
        arr = backend.array(a.name)
        shape, want = tuple(arr.shape), shape_of(a, rows[a.per], sizes)
        if -1 not in want and shape != want:
            problems.append(f"array '{a.name}' has shape {shape}, expected {want}")
        elif -1 in want and (len(shape) != len(want) or any(s < 1 if w == -1 else s != w
                                                             for s, w in zip(shape, want, strict=True))):
            text = ", ".join("width >= 1" if w == -1 else str(w) for w in want)
            problems.append(f"array '{a.name}' has shape {shape}, expected ({text})")
        if np.dtype(arr.dtype) != np.dtype(a.dtype):
            problems.append(f"array '{a.name}' has dtype {arr.dtype}, expected {np.dtype(a.dtype)}")
    return problems


def encode_strings(values: list[str]) -> np.ndarray:
    """(E, L) uint8 NUL-padded UTF-8 matrix of `values` (L >= 1)."""
    raw = [v.encode() for v in values]
    width = max([1, *map(len, raw)])
    return np.array(raw, f"S{width}").view(np.uint8).reshape(len(raw), width)


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


def box_problems(box: np.ndarray, move: np.ndarray) -> list[str]:
    """Boxes and movements are finite. Nothing more: ODMD's perturbed detections reach past the
    image's edge and even have a negative width (perturb-detection-val frame 23358); a missed
    detection has width 0."""
    bad = np.nonzero(~np.all(np.isfinite(box), axis=1))[0]
    problems = [f"box is not finite at frame(s) {_first(bad)}"] * bool(len(bad))
    moved = np.nonzero(~np.all(np.isfinite(move), axis=1))[0]
    if len(moved):
        problems.append(f"move is not finite at frame(s) {_first(moved)}")
    return problems
