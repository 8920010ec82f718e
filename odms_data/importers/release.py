"""Importing the official ODMS release (the authors' `data/` folder) into eight verified stores.

Layout and oddities of the release: ../shared/data/README.md, summarised here.
- `{val,test}/{robot,driving,normal,perturb}/<folder>/<name>.png`, one folder per approach.
- robot, normal, perturb: the file name is z in micrometres; the object sits at z = 0, so
  depth = z. robot folders hold 30 frames, stored once, that the benchmark protocol expands
  into 55 windowed examples of 10 observations; normal and perturb folders are one example each.
- driving: `info.txt` holds a header, then `camera_move(m) depth(m)` per PNG in name order; the
  sequence is stored farthest first, so it is reversed here (closest first, z = camera_move) and
  d1 is the depth at the closest frame. Objects move, so depth is stored per frame.
Oddities are kept as released and recorded in the store's `oddities` attribute. A store whose
content differs from its manifest in splits/ is never given the official split name.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import DigestMismatchError, InputError, OdmsError, OutputExistsError
from ..inputs import listed_inside, read_input
from ..protocol import OFFICIAL_SPLITS, ROBOT_FRAMES, ROBOT_N_OBS, ROBOT_WINDOWS, protocol_windows
from ..store.format import StoreAttrs, store_path
from ..store.manifests import check_against_manifest, load_manifest, split_names
from ..store.oddity import SKIPPED, Oddity
from ..store.reader import open_store
from .builder import Importer, Progress
from .decoding import Workers
from .mask_files import MaskFile
from .plan import MaskPlan, Skips
from .result import ImportResult

# (frames per mask chunk, frames per shard): robot one folder per chunk, normal/perturb one example.
CHUNKING = {"robot": (30, 480), "driving": (32, 1024), "normal": (10, 2000), "perturb": (10, 2000)}
MODIFIED = "-modified"  # the suffix of a split whose content differs from its manifest
MAX_INFO_BYTES = 1 << 24  # a driving folder's info.txt: a short line per PNG
RELEASE = "official ODMS release (Griffin & Corso, ECCV 2020; griffbr/ODMS data/)"


def _natural_key(name: str) -> list:
    return [int(t) if t.isdigit() else t for t in re.split(r"(\d+)", name)]


@dataclass
class Folder:
    """One release folder: its frames in store order and the examples made of them."""

    rel: str  # path relative to the data dir, e.g. "test/robot/banana_0"
    files: list[Path]
    z: np.ndarray
    depth: np.ndarray
    examples: list[tuple[str, np.ndarray, float]]  # (id, frame offsets, d1)


def _numbered_pngs(folder: Path) -> tuple[list[Path], np.ndarray]:
    """The folder's PNGs sorted by the number in their name, and those numbers."""
    pngs = listed_inside(folder, lambda p: p.suffix.lower() == ".png" and not p.name.startswith("."))
    for p in pngs:
        if not re.fullmatch(r"[0-9]+", p.stem):
            raise InputError(f"{p}: file name is not a number (the release names each mask by its "
                             "position, e.g. 173654.png)")
    pngs.sort(key=lambda p: int(p.stem))
    nums = np.array([int(p.stem) for p in pngs], np.int64)
    dup = np.nonzero(np.diff(nums) == 0)[0]
    if len(dup):
        raise InputError(f"{pngs[dup[0] + 1]}: same position as {pngs[dup[0]].name}")
    if len(pngs) < 2:
        raise InputError(f"{folder}: has {len(pngs)} PNG file(s), at least 2 are needed")
    return pngs, nums


def _read_info(path: Path, n_pngs: int) -> tuple[np.ndarray, np.ndarray]:
    """camera_move and depth per PNG, in name order, from a driving folder's info.txt."""
    if not path.exists():
        raise InputError(f"{path}: missing (driving folders need camera_move and depth per PNG)")
    try:
        lines = read_input(path, "a driving folder's info.txt", MAX_INFO_BYTES).decode().splitlines()
    except UnicodeDecodeError as e:
        raise InputError(f"{path}: cannot be read ({e})") from None
    if not lines or not lines[0].strip().startswith("camera_move"):
        raise InputError(f"{path} line 1: expected the header 'camera_move(m) depth(m)'")
    rows = [(i + 2, line.split()) for i, line in enumerate(lines[1:]) if line.strip()]
    if len(rows) != n_pngs:
        what = "missing" if len(rows) < n_pngs else "extra"
        raise InputError(f"{path}: {len(rows)} data lines for {n_pngs} PNGs ({what} lines)")
    values = np.empty((n_pngs, 2))
    for k, (lineno, parts) in enumerate(rows):
        if len(parts) != 2:
            raise InputError(f"{path} line {lineno}: expected 2 values (camera_move depth), got {len(parts)}")
        for j, text in enumerate(parts):
            try:
                values[k, j] = float(text)
            except ValueError:
                raise InputError(f"{path} line {lineno}: '{text}' is not a number") from None
        if not math.isfinite(values[k, 0]):
            raise InputError(f"{path} line {lineno}: camera_move '{parts[0]}' is not finite")
    return values[:, 0], values[:, 1]


def _scan_folder(folder: Path, rel: str, split: str, domain: str) -> Folder:
    pngs, nums = _numbered_pngs(folder)
    name = folder.name
    if domain == "driving":
        move, depth = _read_info(folder / "info.txt", len(pngs))
        files, z, depth = pngs[::-1], move[::-1].copy(), depth[::-1].copy()
        d1 = float(depth[0])
        return Folder(rel, files, z, depth, [(f"{split}/{name}", np.arange(len(files)), d1)])
    z = nums / 1e6
    if domain != "robot":
        return Folder(rel, pngs, z, z.copy(), [(f"{split}/{name}", np.arange(len(pngs)), float(z[0]))])
    if len(pngs) != ROBOT_FRAMES:
        raise InputError(f"{folder}: has {len(pngs)} PNGs; robot folders need {ROBOT_FRAMES}")
    examples = [(f"{split}/{name}/w{w}-{s:02d}", idx, float(z[idx[0]]))
                for w, s, idx in protocol_windows(len(pngs), ROBOT_WINDOWS, ROBOT_N_OBS)]
    return Folder(rel, pngs, z, z.copy(), examples)


def scan_split(data_dir: Path, split: str, skip_bad: bool) -> tuple[list[Folder], list[Oddity]]:
    """The folders of one official split, and (with skip_bad) the ones skipped as oddities."""
    domain, fold = split.split("-")
    root = data_dir / fold / domain
    if not root.is_dir():
        below = data_dir / "data"
        hint = (f"; did you mean {below}? (DATA_DIR is the release's data/ folder)" if (below / fold).is_dir()
                else " (DATA_DIR is the release's data/ folder, holding val/ and test/)")
        raise InputError(f"{root}: no such folder{hint}")
    dirs = sorted((p for p in root.iterdir() if p.is_dir()), key=lambda p: _natural_key(p.name))
    if not dirs:
        raise InputError(f"{root}: holds no example folders")
    folders, skips = [], Skips(skip_bad)
    for d in dirs:
        try:
            folders.append(_scan_folder(d, f"{fold}/{domain}/{d.name}", split, domain))
        except InputError as e:
            skips.add(f"{split}/{d.name}", e)
    return folders, skips.oddities


def make_plan(split: str, folders: list[Folder], skipped: list[Oddity]) -> MaskPlan:
    domain = split.split("-")[0]
    masks: list[MaskFile] = []
    z, depth, rows = [], [], []
    d1: list[float] = []
    ids: list[str] = []
    sources: list[str] = []
    for f in folders:
        base = len(masks)
        masks += map(MaskFile, f.files)
        z.append(f.z)
        depth.append(f.depth)
        for eid, offsets, label in f.examples:
            rows.append(base + offsets)
            d1.append(label if math.isfinite(label) and label > 0 else math.nan)
            ids.append(eid)
            sources.append(f.rel)
    width = max((len(r) for r in rows), default=1)
    frame_index = np.full((len(rows), width), -1, np.int64)
    for i, r in enumerate(rows):
        frame_index[i, : len(r)] = r
    fpc, fps = CHUNKING[domain]
    fold = split.split("-")[1]
    return MaskPlan(
        split=split, domain=domain, source=f"{RELEASE}, {fold}/{domain}",
        masks=masks, z=np.concatenate(z) if z else np.zeros(0), depth=np.concatenate(depth) if depth
        else np.zeros(0), frame_index=frame_index, d1=np.array(d1, np.float64), ids=ids,
        sources=sources, frames_per_chunk=fpc, frames_per_shard=fps, oddities=list(skipped),
        id_room=len(MODIFIED),
    )


def _folder_of(folders: list[Folder], row: int) -> int:
    """Index of the folder holding frame row `row`."""
    ends = np.cumsum([len(f.files) for f in folders])
    return int(np.searchsorted(ends, row, side="right"))


@dataclass
class SplitImporter(Importer):
    """One official split's folders as scanned, less those left out so far."""

    name: str
    folders: list[Folder]
    skipped: list[Oddity]
    path: Path
    verify: bool
    skip_bad: bool = False

    def plan(self) -> MaskPlan:
        return make_plan(self.name, self.folders, self.skipped)

    def drop(self, plan: MaskPlan, failures: list[tuple[int, str]]) -> None:
        bad: dict[int, str] = {}
        for row, message in failures:
            bad.setdefault(_folder_of(self.folders, row), message)
        self.skipped = self.skipped + [
            Oddity(SKIPPED, f"{self.name}/{Path(self.folders[i].rel).name}", m) for i, m in bad.items()
        ]
        self.folders = [f for i, f in enumerate(self.folders) if i not in bad]

    def check(self, attrs: StoreAttrs) -> None:
        _verify(attrs, self.name, self.path, strict=self.verify and not self.skipped)


def _check_request(data_dir: Path, out_dir: Path, names: list[str], fmt: str) -> None:
    if not data_dir.is_dir():
        raise InputError(f"{data_dir}: no such folder (give the release's data/ folder)")
    if out_dir.exists() and not out_dir.is_dir():
        raise OutputExistsError(f"{out_dir}: is a file; give a folder for the stores")
    unknown = [n for n in names if n not in OFFICIAL_SPLITS]
    if unknown:
        raise InputError(f"unknown official split '{unknown[0]}'; known: {', '.join(OFFICIAL_SPLITS)}")
    if fmt not in ("zarr", "hdf5"):
        raise InputError(f"unknown store format '{fmt}'; use zarr or hdf5")


def import_release(
    data_dir: str | Path,
    out_dir: str | Path,
    *,
    splits: list[str] | None = None,
    fmt: str = "zarr",
    overwrite: bool = False,
    progress: Progress | None = None,
    skip_bad: bool = False,
    verify: bool = True,
    workers: int | None = None,
) -> list[ImportResult]:
    """Import the release at `data_dir` into `<out_dir>/<split>.zarr` (or .h5) for each split.

    A store already at its path, complete and matching its split's manifest (one an interrupted
    import finished), is kept and its split not imported again, unless `overwrite`; the other
    requested splits are imported. Every folder of every split to import is scanned before
    anything is written. With
    `skip_bad`, bad folders are left out and recorded as oddities of kind "skipped"; such a store
    (or, with `verify=False`, any store differing from its manifest) is named `<split>-modified`,
    and so are its ids (`<split>-modified/...`).
    Otherwise a store that differs from its manifest raises DigestMismatchError and is not
    written. `progress(split, frames_done, frames_total)` follows the decoding.
    """
    data_dir, out_dir = Path(data_dir), Path(out_dir)
    names = list(splits or OFFICIAL_SPLITS)
    _check_request(data_dir, out_dir, names, fmt)
    kept = {} if overwrite else {n: r for n in names if (r := kept_store(store_path(out_dir, n, fmt), n))}
    scans = {name: scan_split(data_dir, name, skip_bad) for name in names if name not in kept}
    out: list[ImportResult] = []
    with Workers(workers) as pool:
        for name in names:
            if name in kept:
                out.append(kept[name])
                continue
            path = store_path(out_dir, name, fmt)
            source = SplitImporter(name, *scans[name], path, verify, skip_bad)
            out.append(source.write(path, fmt, pool, overwrite=overwrite, progress=progress))
    return out


def kept_store(path: Path, name: str) -> ImportResult | None:
    """The store at `path` as a result to keep, when an earlier import left it complete and
    matching split `name`'s manifest (the import resumes after it); None otherwise, so that a
    store that is not such is refused as existing (or replaced with `overwrite`)."""
    if not path.exists():
        return None
    try:
        with open_store(str(path)) as store:
            attrs = store.attrs
        if attrs.split != name:
            return None
        check_against_manifest(attrs, load_manifest(name), str(path))
    except (OdmsError, OSError):
        return None
    return ImportResult(str(path), name, attrs, kept=True)


def _verify(attrs: StoreAttrs, name: str, path: Path, strict: bool) -> None:
    """Check a store against splits/<name>.json; a non-strict mismatch renames the split."""
    if name not in split_names():
        return
    try:
        check_against_manifest(attrs, load_manifest(name), str(path))
    except DigestMismatchError as e:
        if strict:
            raise DigestMismatchError(f"{e}; nothing was written") from None
        attrs.split = f"{name}{MODIFIED}"
        attrs.source = f"{attrs.source}; modified, differs from splits/{name}.json"
