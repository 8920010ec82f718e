"""`odms-data import odmd`: ODMD's pickled val/test sets (griffbr/ODMD, data/) into stores of
boxes, one per set, each checked against its manifest in splits/.

A set is a dict (docs/ODMD.md): `bb.bboxes` (P, 5, E) rows [x_c, y_c, w, h, depth] per position,
far to near, `bb_3D.camera_movement` (P - 1, 3, E) from each position to the last, and
`bb.image_dim` [H, W]. Example e becomes the store's example `<split>/<e:05d>`: its P frames in
ODMD's order, box and depth per frame (NaN where ODMD writes 0: the robot sets' inner frames),
the movement (0 at the last frame) and the label, the depth at the last frame. The pickles are
read by pickles.py, which runs none of their code; every shape is checked here before
anything is allocated from it. Each set is an `Importer` (builder.py) of a store of boxes.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import InputError
from ..inputs import inside
from ..pickles import load_pickle
from ..protocol import BENCHMARKS, SPLIT_FAMILIES
from ..store.box_store import BoxRows
from ..store.format import StoreAttrs, store_path
from ..store.manifests import check_against_manifest, load_manifest, split_names
from .builder import Importer, Progress
from .plan import BoxPlan
from .result import ImportResult

MAX_POSITIONS = 1000  # ODMD's sets have 10
# split -> (its pickle under data/, its store's domain): ODMD's sets, then its conversion of ODMS's
ODMD_SETS: dict[str, tuple[str, str]] = {
    **{BENCHMARKS["odmd"].split(d, f): (f"odmd/{f}/{f}_{d}.pk", "odmd")
       for f in SPLIT_FAMILIES for d in BENCHMARKS["odmd"].domains},
    **{BENCHMARKS["odms-detection"].split(d, f): (f"odms_detection/{f}/{f}_odms_detect_{d}.pk", d)
       for f in SPLIT_FAMILIES for d in BENCHMARKS["odms-detection"].domains},
}
SOURCE = "griffbr/ODMD data/"


def _array(d: Any, keys: tuple[str, str], ndim: int, where: str) -> np.ndarray:
    group = d.get(keys[0]) if isinstance(d, dict) else None
    value = group.get(keys[1]) if isinstance(group, dict) else None
    if not isinstance(value, np.ndarray) or value.ndim != ndim or value.dtype.kind not in "fiu":
        raise InputError(f"{where}: '{keys[0]}.{keys[1]}' is not a {ndim}-D numeric array, "
                         "as ODMD's sets hold")
    return value.astype(np.float64)


def _image_dim(d: dict, where: str) -> tuple[int, int]:
    dim = d["bb"].get("image_dim")
    if (not isinstance(dim, list | tuple) or len(dim) != 2
            or not all(isinstance(v, int | np.integer) and 0 < v <= 2**16 for v in dim)):
        raise InputError(f"{where}: 'bb.image_dim' {str(dim)[:40]} is not [height, width] in pixels")
    return int(dim[0]), int(dim[1])


def read_set(path: Path, split: str) -> BoxPlan:
    """The examples of one ODMD pickle as the plan of a store of boxes of `split`."""
    d = load_pickle(path)
    bb = _array(d, ("bb", "bboxes"), 3, str(path))
    cm = _array(d, ("bb_3D", "camera_movement"), 3, str(path))
    P, E = bb.shape[0], bb.shape[2]
    if bb.shape[1] != 5 or not 2 <= P <= MAX_POSITIONS or E < 1:
        raise InputError(f"{path}: 'bb.bboxes' has shape {bb.shape}, not (positions, 5, examples)")
    if cm.shape != (P - 1, 3, E):
        raise InputError(f"{path}: 'bb_3D.camera_movement' has shape {cm.shape}, expected {(P - 1, 3, E)}")
    move = np.zeros((E, P, 3))
    move[:, :-1] = cm.transpose(2, 0, 1)
    depth = bb[:, 4, :].T.copy()
    depth[depth == 0] = np.nan  # ODMD's robot sets write 0 where a frame's depth is unknown
    rel = path.name
    rows = BoxRows(
        boxes=bb[:, :4, :].transpose(2, 0, 1).copy(), move=move, depth=depth, d1=depth[:, -1].copy(),
        ids=[f"{split}/{e:05d}" for e in range(E)], sources=[f"{rel}#{e}" for e in range(E)],
    )
    file, domain = ODMD_SETS[split]
    return BoxPlan(split=split, domain=domain, source=SOURCE + file, rows=rows,
                   image_size=_image_dim(d, str(path)))


@dataclass
class OdmdImporter(Importer):
    """One of ODMD's sets: its pickle, planned as a store of boxes, which is checked against the
    set's manifest where there is one. `store` is where it goes (named in a mismatch)."""

    split: str
    pickle: Path
    store: Path

    def plan(self) -> BoxPlan:
        return read_set(self.pickle, self.split)

    def check(self, attrs: StoreAttrs) -> None:
        if attrs.split in split_names():
            check_against_manifest(attrs, load_manifest(attrs.split), str(self.store))


def import_odmd(
    data_dir: str | Path, out_dir: str | Path, *, splits: list[str] | None = None, fmt: str = "zarr",
    overwrite: bool = False, progress: Progress | None = None,
) -> list[ImportResult]:
    """Import ODMD's sets under `data_dir` (ODMD's data/ folder) into `<out_dir>/<split>.zarr`
    (or .h5), each checked against splits/<split>.json where there is one (DigestMismatchError,
    nothing written, when it differs). Every requested pickle must exist before anything is
    written. `progress(split, frames_done, frames_total)` after each store."""
    data_dir, out_dir = Path(data_dir), Path(out_dir)
    names = list(splits or ODMD_SETS)
    unknown = [n for n in names if n not in ODMD_SETS]
    if unknown:
        raise InputError(f"unknown ODMD set '{unknown[0]}'; the sets are {', '.join(ODMD_SETS)}")
    if not data_dir.is_dir():
        raise InputError(f"{data_dir}: not a folder; give ODMD's data/ folder "
                         "(odmd/ and odms_detection/ inside)")
    files = {n: inside(data_dir, ODMD_SETS[n][0], f"ODMD's set {n}") for n in names}
    for n, f in files.items():
        if not f.is_file():
            raise InputError(f"{f}: ODMD's set {n} is not there; give ODMD's data/ folder")
    stores = {n: store_path(out_dir, n, fmt) for n in names}
    return [OdmdImporter(n, files[n], stores[n]).write(stores[n], fmt, overwrite=overwrite, progress=progress)
            for n in names]
