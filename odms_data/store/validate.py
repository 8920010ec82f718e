"""Checking a store against schemas/FORMAT.md: attributes, shapes, invariants, statistics, digest."""

from __future__ import annotations

from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from ..errors import InputError, OdmsError
from .backends import open_backend
from .digest import recompute_digest
from .format import EXAMPLE_ARRAYS, FRAME_ARRAYS, Z_ODDITY, attribute_problems, layout_problems
from .manifests import SplitManifest, load_manifest, split_names
from .masks import mask_stats, packed_width, unpack
from .reader import Store, open_store


@dataclass
class Report:
    """What `validate` found: problems make a store invalid, warnings are recorded oddities."""

    path: str
    problems: list[str] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)
    digest: str | None = None

    @property
    def ok(self) -> bool:
        return not self.problems


def validate(path: str, progress: Callable[[int], None] | None = None) -> Report:
    """Every problem of the store at `path`, one line each; never raises for a bad store.
    `progress(k)` is called as each block of k frames' masks has been checked."""
    report = Report(str(path))
    try:
        backend = open_backend(str(path), "r")
    except OdmsError as e:
        report.problems.append(str(e))
        return report
    try:
        raw = backend.read_attrs()
        if raw is None:
            report.problems.append("no 'odms' attribute: not an odms-data store")
            return report
        report.problems += [f"attributes {p}" for p in attribute_problems(raw)]
        if raw.get("complete") is not True:
            report.problems.append("store is incomplete (an interrupted write?)")
        missing = sorted((set(FRAME_ARRAYS) | set(EXAMPLE_ARRAYS)) - backend.names())
        if missing:
            report.problems.append(f"missing array(s): {', '.join(missing)}")
        if report.problems:
            return report
        report.problems += layout_problems(backend, raw)
    except OdmsError as e:
        report.problems.append(str(e))
    finally:
        backend.close()
    if report.problems:
        return report
    try:
        with open_store(str(path)) as store:
            _check_content(store, report, progress)
    except OdmsError as e:
        report.problems.append(str(e))
    return report


def _check_content(store: Store, report: Report, progress: Callable[[int], None] | None) -> None:
    P = report.problems
    F, E = store.n_frames, store.n_examples
    fi = store.frame_index
    if fi.size and (fi.min() < -1 or fi.max() >= F):
        P.append(f"frame_index holds values outside -1..{F - 1}")
        return
    padded = fi < 0
    if np.any(padded[:, :-1] & ~padded[:, 1:]):
        row = int(np.nonzero((padded[:, :-1] & ~padded[:, 1:]).any(axis=1))[0][0])
        P.append(f"example {store.example_ids[row]}: -1 padding is followed by a frame index")
    n_obs = store.n_obs
    for i in np.nonzero(n_obs < 2)[0][:5]:
        P.append(f"example {store.example_ids[i]}: has {n_obs[i]} frame(s), at least 2 needed")
    if not np.all(np.isfinite(store.z)):
        P.append(f"z is not finite at frame(s) {_first(np.nonzero(~np.isfinite(store.z))[0])}")
    excused = {o["example"] for o in store.attrs.oddities if o["kind"] == Z_ODDITY}
    z = np.where(fi >= 0, store.z[np.maximum(fi, 0)], np.inf)
    with np.errstate(invalid="ignore"):  # inf - inf in the padding of shorter examples
        steps = np.diff(z, axis=1)
    bad = np.nonzero(np.any(steps <= 0, axis=1) & (n_obs >= 2))[0]
    for i in bad:
        msg = f"example {store.example_ids[i]}: z is not strictly increasing"
        (report.warnings if store.example_ids[i] in excused else P).append(
            msg + (" (recorded oddity)" if store.example_ids[i] in excused else "")
        )
    d1 = store.d1
    labelled = ~np.isnan(d1)
    wrong = labelled & ~(np.isfinite(d1) & (d1 > 0))
    for i in np.nonzero(wrong)[0][:5]:
        P.append(f"example {store.example_ids[i]}: d1 = {d1[i]} is not a positive depth")
    if int(labelled.sum()) != store.attrs.counts["labelled"]:
        P.append(f"counts.labelled is {store.attrs.counts['labelled']}, but {int(labelled.sum())} "
                 "examples have d1")
    ids = store.example_ids
    if len(set(ids)) != E:
        dup = sorted(x for x, c in Counter(ids).items() if c > 1)[:3]
        P.append(f"example ids are not unique: {', '.join(dup)}")
    if any(not x for x in ids):
        P.append("an example id is empty")
    _check_masks(store, report, progress)


def _check_masks(store: Store, report: Report, progress: Callable[[int], None] | None) -> None:
    W, pad_bits = store.width, packed_width(store.width) * 8 - store.width
    pad_mask = np.uint8((1 << pad_bits) - 1) if pad_bits else None
    wrong_stats: list[int] = []

    def visit(start: int, block: np.ndarray) -> None:
        if pad_mask is not None and np.any(block[:, :, -1] & pad_mask):
            report.problems.append(f"masks of frames {start}..: padding bits are not zero")
        masks = unpack(block, W)
        for j, m in enumerate(masks):
            f = start + j
            area, largest, bbox = mask_stats(m)
            if (area != store.area[f] or largest != store.largest_area[f]
                    or tuple(store.bbox[f]) != bbox):
                wrong_stats.append(f)
        if progress:
            progress(len(block))

    try:
        digest, _ = recompute_digest(store, visit)
    except OdmsError as e:
        report.problems.append(f"{e}; the digest could not be recomputed")
        return
    if wrong_stats:
        report.problems.append(
            f"stored area/largest_area/bbox differ from the masks at {len(wrong_stats)} frame(s), "
            f"first {_first(wrong_stats)}"
        )
    report.digest = digest
    if digest != store.attrs.digest:
        report.problems.append(f"content digest {digest} differs from the recorded {store.attrs.digest}")
    if store.attrs.split in split_names():
        try:
            manifest = load_manifest(store.attrs.split)
        except InputError as e:
            report.problems.append(str(e))
            return
        if manifest.digest != digest:
            report.problems.append(
                f"content digest {digest} differs from splits/{manifest.name}.json ({manifest.digest})"
                + _version_hint(store.attrs.generator_version, manifest)
            )


def _version_hint(version: int | None, manifest: SplitManifest) -> str:
    if version is None or version == manifest.generator_version:
        return ""
    return (f": the store was made by generator version {version}, the split is version "
            f"{manifest.generator_version}'s (odms-data generate --split {manifest.name})")


def _first(values, k: int = 5) -> str:
    values = list(values)
    return ", ".join(str(int(v)) for v in values[:k]) + (", ..." if len(values) > k else "")
