"""The kinds of example a source gives, and how each becomes a batch of a model's inputs: masks
(ODMS's, for ODN, through transforms.Transform) and boxes (ODMD's, for DBox, through
box_transform.BoxTransform; a store of masks gives its boxes through the box rule).

A kind reads a batch from a store's rows and draws one from the generator, into arrays made by
`empty`; the source (sources.py) owns everything else. A transform names its kind (`kind`),
generator parameters are of one kind's type.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..errors import InputError
from ..simulate.batch_render import render_masks, render_shrunk
from ..simulate.box_examples import BoxParams, sample_box_examples
from ..simulate.object_model import sample_examples
from ..simulate.params import PRESETS, GeneratorParams
from ..simulate.shrink import shrink_packed
from ..store.box_rule import example_boxes
from ..store.masks import unpack
from ..store.reader import Store
from .box_transform import DBOX_TRANSFORM, BoxTransform
from .transforms import PAPER_TRANSFORM, Transform

STANDARD = PRESETS["standard"]
RENDER_CHUNK = 32  # examples drawn together: bounds the scratch images to a few MB

InputTransform = Transform | BoxTransform  # a model's inputs from one kind of example
Params = GeneratorParams | BoxParams  # generator parameters of one kind of example
Indices = Sequence[int] | np.ndarray  # example rows or generator indices
Empty = Callable[[tuple[int, ...], np.dtype], np.ndarray]  # allocates a batch's array


def collate(examples: list[dict[str, Any]], empty: Empty = np.empty) -> dict[str, np.ndarray]:
    """Stack examples' arrays along a new first axis, into arrays made by `empty`."""
    out = {}
    for key in examples[0]:
        first = np.asarray(examples[0][key])
        into = empty((len(examples), *first.shape), first.dtype)
        try:
            out[key] = np.stack([e[key] for e in examples], out=into)
        except ValueError:
            shapes = sorted({np.shape(e[key]) for e in examples})
            raise InputError(
                f"cannot batch '{key}': examples give shapes {shapes}; set the transform's n_obs "
                "so every example has as many observations"
            ) from None
    return out


def copied(arrays: dict[str, np.ndarray], empty: Empty) -> dict[str, np.ndarray]:
    """`arrays`, each copied into an array made by `empty`."""
    out = {}
    for key, a in arrays.items():
        out[key] = empty(a.shape, a.dtype)
        out[key][...] = a
    return out


# --- masks: ODN's inputs --------------------------------------------------------------------

def _mask_inputs(store: Store, t: Transform, i: int, chosen: np.ndarray, packed: np.ndarray,
                 masks: np.ndarray | None = None) -> dict[str, Any]:
    """Example i's inputs from the packed masks of its frames `chosen`; shrunk masks are written
    into `masks` when given."""
    if t.size is None:
        out = t(unpack(packed, store.width), store.z[chosen], float(store.d1[i]))
    else:  # read and shrink only the stored boxes: the same pixels
        shrunk = shrink_packed(packed, store.width, store.bbox[chosen], t.size, not t.rounded, masks)
        out = {"masks": shrunk, **t.vectors(store.z[chosen], float(store.d1[i]), t.size)}
    out["index"] = np.int64(i)
    return out


def _read_packed(store: Store, path: str, t: Transform, rows: np.ndarray
                 ) -> list[tuple[int, np.ndarray, np.ndarray]]:
    """(row, chosen frames, their packed masks) of each row; the packed masks of nearby rows are
    read in one slice."""
    chosen = []
    for i in rows:
        frames = store.frames_of(int(i))
        try:
            chosen.append(frames[t.select(len(frames))])
        except InputError as e:
            raise InputError(f"{path}: example {store.example_ids[i]}: {e}") from None
    flat = np.concatenate(chosen)
    lo, hi = int(flat.min()), int(flat.max()) + 1
    pairs = zip(rows.tolist(), chosen, strict=True)
    if hi - lo > 4 * len(flat):
        return [(i, c, store.read_packed_frames(c)) for i, c in pairs]
    packed = store.read_packed(lo, hi)
    return [(i, c, packed[c - lo]) for i, c in pairs]


def _read_masks(store: Store, path: str, rows: np.ndarray, t: Transform, empty: Empty
                ) -> dict[str, np.ndarray]:
    """Examples by row; shrunk masks are written into the batch's array directly."""
    read = _read_packed(store, path, t, rows)
    if t.size is None or len({len(c) for _, c, _ in read}) > 1:  # collate says what differs
        return collate([_mask_inputs(store, t, *r) for r in read], empty)
    dtype = np.dtype(np.uint8 if t.rounded else np.float32)
    masks = empty((len(read), len(read[0][1]), *t.size), dtype)
    rest = [_mask_inputs(store, t, *r, masks=m) for r, m in zip(read, masks, strict=True)]
    for e in rest:
        del e["masks"]
    return {"masks": masks, **collate(rest, empty)}


def _draw_masks(p: GeneratorParams, seed: int, indices: Indices, t: Transform, direct: bool,
                empty: Empty) -> dict[str, np.ndarray]:
    """The examples at generator `indices`, drawn together (simulate.batch_render), a few dozen
    at a time. By default their masks are exactly those of a generated store read through the
    same transform (full-size masks shrunk with INTER_AREA), drawn without a full-size frame
    (batch_render.render_shrunk); `direct` draws the contour straight at the transform's size
    instead (the generator's own small-size rendering): faster, but its masks are larger
    (docs/LOADERS.md)."""
    chosen = t.select(p.n_obs)
    specs = sample_examples(p, seed, indices)
    size = t.size or p.image_size
    dtype = np.dtype(np.uint8 if t.rounded else np.float32)
    masks = empty((len(specs), len(chosen), *size), dtype)
    for start in range(0, len(specs), RENDER_CHUNK):
        part, into = specs[start : start + RENDER_CHUNK], masks[start : start + RENDER_CHUNK]
        if t.size is not None and not direct:
            render_shrunk(part, p, size, chosen, not t.rounded, into)
        elif dtype == np.uint8:
            render_masks(part, p, t.size, chosen, into)
        else:  # coverage of masks at their drawn size: the 0/1 masks as float32
            into[...] = render_masks(part, p, t.size, chosen)
    vectors = collate([t.vectors(s.z[chosen], float(s.z[0]), size) for s in specs], empty)
    return {"masks": masks, **vectors, **copied({"index": np.asarray(indices, np.int64)}, empty)}


# --- boxes: DBox's inputs -------------------------------------------------------------------

def _read_boxes(store: Store, path: str, rows: np.ndarray, t: BoxTransform, empty: Empty
                ) -> dict[str, np.ndarray]:
    """Examples by row as box examples (store/box_rule.py: a store of boxes, or of masks through
    the box rule)."""
    e = example_boxes(store, rows, t.n_obs)
    try:
        made = t.batch(e.boxes, e.move, e.depth)
    except InputError as err:
        raise InputError(f"{path}: {err}") from None
    return copied({**made, "index": rows}, empty)


def _draw_boxes(p: BoxParams, seed: int, indices: Indices, t: BoxTransform, direct: bool,
                empty: Empty) -> dict[str, np.ndarray]:
    """The box examples at generator `indices` (simulate/box_examples.py)."""
    g = sample_box_examples(p, seed, indices)
    return copied({**t.batch(g["boxes"], g["move"], g["depth"]), "index": np.asarray(indices, np.int64)},
                  empty)


@dataclass(frozen=True)
class Kind:
    """A kind of example: its name, the transform that makes a model's inputs of it (and its
    default), its generator parameters (and their number of frames), and how a batch is read from
    a store's rows or drawn from the generator."""

    name: str
    noun: str
    transform: type
    default_transform: InputTransform
    params: type
    frames: Callable[[Any], int]
    read: Callable[[Store, str, np.ndarray, Any, Empty], dict[str, np.ndarray]]
    draw: Callable[[Any, int, Indices, Any, bool, Empty], dict[str, np.ndarray]]

    def __reduce__(self) -> tuple[Any, tuple[str]]:
        return kind_named, (self.name,)  # a source sent to a worker takes that process's kind


KINDS = {
    "masks": Kind("masks", "mask", Transform, PAPER_TRANSFORM, GeneratorParams,
                  lambda p: p.n_obs, _read_masks, _draw_masks),
    "boxes": Kind("boxes", "box", BoxTransform, DBOX_TRANSFORM, BoxParams,
                  lambda p: p.num_pos, _read_boxes, _draw_boxes),
}


def kind_named(name: str) -> Kind:
    return KINDS[name]


def kind_of_params(params: Any) -> Kind:
    """The kind of example generator parameters `params` make."""
    for kind in KINDS.values():
        if isinstance(params, kind.params):
            return kind
    raise InputError(f"no kind of example is generated from {type(params).__name__}; give "
                     f"{' or '.join(k.params.__name__ for k in KINDS.values())}")


def transform_for(kind: Kind, transform: InputTransform | None) -> InputTransform:
    """`transform`, or the kind's own when None; refused when it takes another kind of example."""
    if transform is None:
        return kind.default_transform
    if transform.kind != kind.name:
        other = KINDS[transform.kind]
        raise InputError(f"{kind.noun} examples take a {kind.transform.__name__}; a "
                         f"{type(transform).__name__} needs {other.noun} examples "
                         f"({other.noun} generator parameters, {other.params.__name__})")
    return transform
