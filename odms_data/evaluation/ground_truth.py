"""Where ground truth comes from: stores found in the data folder(s), keyed by their split.

The data folders are `--data DIR` (repeatable; a store path works too, and so does a store's
URL, s3://bucket/x.zarr), else the folders in the environment variable ODMS_DATA (separated by
':'), else the user's cache folder ($XDG_CACHE_HOME/odms-data, else ~/.cache/odms-data). Every
store there (`*.zarr`, `*.h5`, `*.hdf5`, `*.hdf`, generated or imported) serves the split its attributes
name, and its example ids start with `<split>/`.

Scoring reads the labels only. Before a leaderboard entry records a store's digest,
`verify_truth` checks it: the store's content (masks, z, depth, labels, ids) recomputed to the
digest it records, and, for a named split, that digest against the split's manifest in splits/.
"""

from __future__ import annotations

import os
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import DigestMismatchError, InputError, StoreError
from ..store.build import Progress
from ..store.digest import check_recorded_digest
from ..store.format import format_of_name
from ..store.manifests import check_against_manifest, load_manifest, split_names
from ..store.reader import open_store
from ..urls import is_url
from ..user_cache import SHOWN, cache_home

ENV_VAR = "ODMS_DATA"
DEFAULT_DATA = SHOWN  # the default data folder, as help texts name it

Location = Path | str  # a local path, or a store's URL, kept as text (a Path folds its '//')


def location(given: str | Path) -> Location:
    """A data folder or store as given: a URL is the URL of one store."""
    return str(given) if is_url(str(given)) else Path(given)


def data_locations(given: Sequence[str] = ()) -> list[Location]:
    """The folders (or stores) to look in: `given`, else $ODMS_DATA, else the default folder."""
    if given:
        return [location(g) for g in given]
    env = os.environ.get(ENV_VAR, "")
    if env.strip():
        return [Path(p) for p in env.split(os.pathsep) if p]
    return [cache_home()]


def _is_store(path: Path) -> bool:
    return format_of_name(path) is not None and not path.name.endswith(".partial")


def find_stores(locations: Iterable[Location]) -> dict[str, Location]:
    """{split: store path} over every store in `locations`; two stores of one split are an error."""
    locations = list(locations)
    paths: list[Location] = []
    for loc in locations:
        if isinstance(loc, str):  # a URL names one store: a bucket is not searched
            paths.append(loc)
        elif (_is_store(loc) and loc.exists()) or (loc / "zarr.json").is_file():  # a store, named any way
            paths.append(loc)
        elif loc.is_dir():
            paths += sorted(p for p in loc.iterdir() if _is_store(p))
        else:
            raise InputError(f"{loc}: no such data folder or store", fix="data")
    return stores_by_split(paths, locations)


def stores_by_split(paths: Iterable[Location], locations: Sequence[Location] = ()) -> dict[str, Location]:
    """{split: store path} of the stores at `paths` (one store named twice counts once); two
    stores of one split are an error."""
    found: dict[str, Location] = {}
    seen: set[Location] = set()
    for p in paths:
        key = p if isinstance(p, str) else p.resolve()
        if key in seen:
            continue
        seen.add(key)
        with open_store(str(p)) as s:
            split = s.attrs.split
        if split in found:
            raise StoreError(f"two stores hold split {split}: {found[split]} and {p}; keep one")
        found[split] = p
    if not found:
        where = ", ".join(str(loc) for loc in locations)
        raise InputError(f"no stores (*.zarr, *.h5) in {where}", fix="no-stores")
    return found


@dataclass
class SplitTruth:
    """The labels of one split, read from its store."""

    split: str
    domain: str
    path: str
    digest: str
    example_ids: list[str]
    d1: np.ndarray  # (E,) m, NaN when unlabelled
    sources: list[str] = field(default_factory=list)  # (E,) each example's recorded source
    n_obs: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))  # (E,) frames
    window: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))  # (E,) frames spanned
    motion: np.ndarray = field(default_factory=lambda: np.zeros(0))  # (E,) camera travel, m

    @property
    def labelled_ids(self) -> list[str]:
        keep = (~np.isnan(self.d1)).tolist()
        return [e for e, k in zip(self.example_ids, keep, strict=True) if k]


def load_truth(path: Location) -> SplitTruth:
    """The ids and labels of the store at `path`, and what the breakdowns group its examples by:
    source, observations, frames spanned and the camera's travel (no masks are read)."""
    with open_store(str(path)) as s:  # the reader refuses ids that are not unique or lack '<split>/'
        ids, d1, fi, n_obs = s.example_ids, s.d1, s.frame_index, s.n_obs
        rows = np.arange(len(fi))
        first, last = fi[:, 0], fi[rows, np.maximum(n_obs - 1, 0)]
        if s.kind == "boxes":  # a box store's movement runs from each frame to the example's last
            motion = np.linalg.norm(s.move[first], axis=1) if len(fi) else np.zeros(0)
        else:
            motion = np.abs(s.z[last] - s.z[first]) if len(fi) else np.zeros(0)
        return SplitTruth(s.attrs.split, s.attrs.domain, str(path), s.attrs.digest, ids, d1, s.sources,
                          n_obs, last - first + 1, motion)


def verify_truth(truth: SplitTruth, progress: Progress | None = None) -> None:
    """StoreError or DigestMismatchError unless the store of `truth` holds the content its digest
    says (every mask read; `progress(split, frames done, frames total)` follows them) and, for a
    named split, that digest is its manifest's; also unless the labels scored are the ones digested."""
    with open_store(truth.path) as s:

        def visit(start: int, block: np.ndarray) -> None:
            if progress:
                progress(truth.split, start + len(block), s.n_frames)

        digest = check_recorded_digest(s, truth.path, visit)
        if digest != truth.digest or not np.array_equal(s.d1, truth.d1, equal_nan=True):
            raise StoreError(f"{truth.path}: changed while it was being scored; score it again")
        if s.attrs.split in split_names():
            try:
                check_against_manifest(s.attrs, load_manifest(s.attrs.split), truth.path)
            except DigestMismatchError as e:
                raise DigestMismatchError(f"{e}; a leaderboard entry is scored on the official content "
                                          "only") from None
