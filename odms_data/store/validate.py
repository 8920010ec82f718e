"""Checking a store against schemas/FORMAT.md: attributes, shapes, invariants, statistics, digest."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from ..errors import InputError, OdmsError, StoreError
from .backends import open_backend
from .build import Progress
from .declared import store_problems
from .digest import recompute_digest
from .format import (
    Z_ODDITY,
    _first,
    arrays_of,
    attribute_problems,
    box_problems,
    d1_problems,
    decode_strings,
    depth_problems,
    frame_index_problems,
    id_problems,
    kind_of,
    stats_problems,
    z_problems,
)
from .manifests import SplitManifest, load_manifest, split_names
from .masks import packed_stats, packed_width
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


def validate(path: str, progress: Progress | None = None) -> Report:
    """Every problem of the store at `path`, one line each; never raises for a bad store.
    `progress(path, frames done, frames total)` is called as each block of masks has been checked."""
    report = Report(str(path))
    try:
        backend = open_backend(str(path), "r")
    except OdmsError as e:  # its message starts with the path, as a problem's line does already
        report.problems.append(str(e).removeprefix(f"{path}: "))
        return report
    try:
        raw = backend.read_attrs()
        if raw is None:
            report.problems.append("no 'odms' attribute: not an odms-data store")
            return report
        report.problems += [f"attributes {p}" for p in attribute_problems(raw)]
        if raw.get("complete") is not True:
            report.problems.append("store is incomplete (an interrupted write?)")
        missing = sorted(set(arrays_of(kind_of(raw))) - backend.names())
        if missing:
            report.problems.append(f"missing array(s): {', '.join(missing)}")
        if report.problems:
            return report
        report.problems += store_problems(backend, raw)
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


def _check_content(store: Store, report: Report, progress: Progress | None) -> None:
    """Every rule of format.py over the arrays as stored, then the masks and the digest."""
    P = report.problems
    split = store.attrs.split
    try:
        ids = store.example_ids
    except StoreError:
        try:
            ids = decode_strings(store.raw("example_id"))
        except UnicodeDecodeError as e:
            P.append(f"array 'example_id' holds invalid UTF-8 ({e})")
            return
        P += id_problems(ids, split)

    def name(i: int) -> str:
        return repr(ids[i])

    try:
        decode_strings(store.raw("source"))
    except UnicodeDecodeError as e:
        P.append(f"array 'source' holds invalid UTF-8 ({e})")
    fi, depth, d1 = store.raw("frame_index"), store.raw("depth"), store.raw("d1")
    index = frame_index_problems(fi, store.n_frames, name)
    P += index + depth_problems(depth) + d1_problems(d1, store.attrs.counts["labelled"], name)
    boxes = store.kind == "boxes"
    if boxes:
        P += box_problems(store.raw("box"), store.raw("move"))
    else:
        P += z_problems(store.raw("z"))
        area, largest, bbox = store.raw("area"), store.raw("largest_area"), store.raw("bbox")
        P += stats_problems(area, largest, bbox, store.height, store.width)
    if index or any("UTF-8" in p for p in P):
        return  # the frames of the examples, or their strings, are unknown
    labelled_at = _check_labels(P, fi, depth, d1, boxes, name)
    if boxes:
        moved = np.nonzero(store.raw("move")[labelled_at].any(axis=1))[0]
        if len(moved):
            P.append(f"example {name(int(moved[0]))}: move at its last frame is not 0 "
                     f"({len(moved)} such example(s))")
        _check_digest(store, report, progress)
        return
    z = store.raw("z")
    n_obs = (fi >= 0).sum(axis=1)
    excused = {o.subject for o in store.attrs.oddities if o.problem == Z_ODDITY}
    zz = np.where(fi >= 0, z[np.maximum(fi, 0)], np.inf)
    with np.errstate(invalid="ignore"):  # inf - inf in the padding of shorter examples
        steps = np.diff(zz, axis=1)
    rows = [ids[row] for row in np.nonzero(np.any(steps <= 0, axis=1) & (n_obs >= 2))[0]]
    recorded = [eid for eid in rows if eid in excused]
    if recorded:  # one line for all: a camera that stops often is one finding, not hundreds
        more = f" and {len(recorded) - 1} more example(s)" if len(recorded) > 1 else ""
        report.warnings.append(f"example {recorded[0]}{more}: z is not strictly increasing (recorded oddity)")
    P += [f"example {eid}: z is not strictly increasing" for eid in rows if eid not in excused]
    _check_masks(store, report, progress)


def _check_labels(P: list[str], fi: np.ndarray, depth: np.ndarray, d1: np.ndarray, boxes: bool,
                  name: Callable[[int], str]) -> np.ndarray:
    """Each label is the depth at its example's labelled frame: the first of a store of masks
    (the closest), the last of one of boxes (ODMD's); returns those frame rows."""
    labelled_at = fi[np.arange(len(fi)), (fi >= 0).sum(axis=1) - 1] if boxes else fi[:, 0]
    at = depth[labelled_at]
    with np.errstate(invalid="ignore"):
        differ = np.nonzero(~np.isnan(d1) & ~np.isnan(at) & (d1 != at))[0]
    if len(differ):
        i = int(differ[0])
        P.append(f"d1 of example {name(i)} is {d1[i]}, but the depth at its {'last' if boxes else 'first'} "
                 f"frame is {at[i]} ({len(differ)} such example(s))")
    return labelled_at


def _check_masks(store: Store, report: Report, progress: Progress | None) -> None:
    W, pad_bits = store.width, packed_width(store.width) * 8 - store.width
    area, largest, bbox = store.raw("area"), store.raw("largest_area"), store.raw("bbox")
    pad_mask = np.uint8((1 << pad_bits) - 1) if pad_bits else None
    wrong_stats: list[int] = []

    def visit(start: int, block: np.ndarray) -> None:
        if pad_mask is not None and np.any(block[:, :, -1] & pad_mask):
            report.problems.append(f"masks of frames {start}..: padding bits are not zero")
        stats, stop = packed_stats(block, W), start + len(block)
        wrong = (stats.area != area[start:stop]) | (stats.largest_area != largest[start:stop]) \
            | np.any(stats.bbox != bbox[start:stop], axis=1)
        wrong_stats.extend((start + np.flatnonzero(wrong)).tolist())
        if progress:
            progress(report.path, start + len(block), store.n_frames)

    if not _check_digest(store, report, None, visit):
        return
    if wrong_stats:
        report.problems.append(
            f"stored area/largest_area/bbox differ from the masks at {len(wrong_stats)} frame(s), "
            f"first {_first(wrong_stats)}"
        )


def _check_digest(store: Store, report: Report, progress: Progress | None,
                  visit: Callable[[int, np.ndarray], None] | None = None) -> bool:
    """The recomputed content digest against the recorded one and the split's manifest; False
    when it could not be recomputed."""
    try:
        digest, _ = recompute_digest(store, visit)
    except OdmsError as e:
        report.problems.append(f"{e}; the digest could not be recomputed")
        return False
    if progress:
        progress(report.path, store.n_frames, store.n_frames)
    report.digest = digest
    if digest != store.attrs.digest:
        report.problems.append(f"content digest {digest} differs from the recorded {store.attrs.digest}")
    _check_manifest(store, report, digest)
    return True


def _check_manifest(store: Store, report: Report, digest: str) -> None:
    """The recomputed digest against the manifest of the store's split, when it is an official one."""
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
            f"{manifest.generator_version}'s (generate split {manifest.name} again)")
