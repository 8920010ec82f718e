"""The object's depth at each frame of a recording (`odms-data estimate`), from the estimates of
the windows that end there, the folder that holds them and its plot.

A recording's store (importers/recording.py) holds the robot protocol's windows over one row of
frames, ordered closest first. A store of boxes (importers/detections.py) gives each window its
own frame rows; its ids (protocol.window_id) name each window's length and first frame, which
give the recording's frame each observation shows (`recorded_frames`). A store of boxes whose
ids do not (another import's) keeps its own rows, one window each. A window's d1 is the depth at
its closest frame, where an approaching camera ends it: the first of its frames in a store of
masks, the last (ODMD's order, far to near) in a store of boxes (`label_frames`). Each frame's
depth is the median of the estimates of the windows ending there; their minimum and maximum give
the spread, and unsolvable windows (a baseline's 0 m) are counted but left out. Frames no window
ends at (the farthest ones, which only longer windows could end at) have no depth.

The folder (`write_estimate`) holds examples.csv, a predictions file (schemas/PREDICTIONS.md)
that `odms-data score` reads, and frames.csv, a row per frame (FRAME_COLUMNS). The plot draws
the depth over the frames, the band from the lowest to the highest window estimate, and the
stored depths where the recording has them.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from ..errors import InputError
from ..extras import pyplot
from ..outputs import OutputType, atomic_file, atomic_folder
from ..protocol import evenly_spaced, window_of_id
from ..store.reader import Store
from .error_plots import plot_format
from .predictions import predictions_table

EXAMPLES, FRAMES = "examples.csv", "frames.csv"
NEEDED_BY = "the depth plot"  # what needs matplotlib, in its error
FRAME_COLUMNS = ("frame", "z", "true_depth", "windows", "unsolvable", "depth_median", "depth_min",
                 "depth_max")


def recorded_frames(store: Store) -> np.ndarray | None:
    """(E, N) the recording's frame (closest first; -1 as padding) each observation of a store of
    boxes from a recording shows, from its examples' ids; None where an id names no window of a
    recording, or its frames do not fit the window."""
    if store.attrs.domain != "recording":
        return None
    n_obs = store.n_obs
    rows = np.full(store.frame_index.shape, -1, np.int64)
    for e, example_id in enumerate(store.example_ids):
        window = window_of_id(example_id, store.attrs.split)
        n = int(n_obs[e])
        if window is None or (window[1] or n) < n:
            return None
        start, length = window
        rows[e, :n] = evenly_spaced(start, start + (length or n) - 1, n)[::-1]  # far to near, as stored
    return rows


def label_frames(store: Store, rows: np.ndarray) -> np.ndarray:
    """(E,) the frame row of `rows` (E, N) each example's d1 is the depth at: its
    first frame in a store of masks, its last in a store of boxes."""
    if store.kind == "boxes":
        return rows[np.arange(len(rows)), store.n_obs - 1]
    return rows[:, 0]


@dataclass(frozen=True)
class FrameDepths:
    """Per frame row of a store: its camera position `z` (NaN in a store of boxes), the stored
    depth `truth` (NaN where unknown), the solved `windows` ending there and the `unsolvable`
    ones, and the median, minimum and maximum of the solved windows' estimates (NaN where none)."""

    z: np.ndarray
    truth: np.ndarray
    windows: np.ndarray
    unsolvable: np.ndarray
    median: np.ndarray
    low: np.ndarray
    high: np.ndarray

    def table(self) -> pd.DataFrame:
        return pd.DataFrame(dict(zip(FRAME_COLUMNS, (
            np.arange(len(self.z)), self.z, self.truth, self.windows, self.unsolvable, self.median, self.low,
            self.high), strict=True)))


def by_frame(frames: np.ndarray, values: np.ndarray, n_frames: int
             ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(count, median, min, max) of `values` grouped by their frame row in `frames`, for rows
    0..n_frames-1 (NaN where a row has none); the median of an even count is the mean of the two
    middle values, as numpy's."""
    order = np.lexsort((values, frames))
    f, v = frames[order], values[order]
    count = np.bincount(f, minlength=n_frames)
    start = np.cumsum(count) - count
    median, low, high = (np.full(n_frames, np.nan) for _ in range(3))
    has = count > 0
    s, c = start[has], count[has]
    low[has], high[has] = v[s], v[s + c - 1]
    median[has] = (v[s + (c - 1) // 2] + v[s + c // 2]) / 2
    return count, median, low, high


def frame_depths(store: Store, d1: np.ndarray, unsolvable: np.ndarray) -> FrameDepths:
    """Each frame's depth from the estimates `d1` (E,) of the store's examples; `unsolvable` (E,)
    marks those left out."""
    recorded = recorded_frames(store) if store.kind == "boxes" else None
    if recorded is None:
        rows, n_frames, truth = store.frame_index, store.n_frames, store.depth
    else:  # the recording's frames, each one's depth from any observation of it
        rows, n_frames, seen = recorded, int(recorded.max()) + 1, recorded >= 0
        truth = np.full(n_frames, np.nan)
        truth[recorded[seen]] = store.depth[store.frame_index[seen]]
    frames = label_frames(store, rows)
    solved = ~unsolvable
    count, median, low, high = by_frame(frames[solved], d1[solved], n_frames)
    z = store.z if store.kind == "masks" else np.full(n_frames, np.nan)
    return FrameDepths(z, truth, count, np.bincount(frames[unsolvable], minlength=n_frames),
                       median, low, high)


def _not_an_estimate(path: Path) -> str | None:
    """What makes `path` something else than an earlier estimate's folder or an empty one."""
    if not path.is_dir():
        return "is a file, not an earlier estimate's folder"
    names = {p.name for p in path.iterdir()}
    if names and names != {EXAMPLES, FRAMES}:
        return f"is a folder odms-data did not write as an estimate (one holds just {EXAMPLES} and {FRAMES})"
    return None


ESTIMATE = OutputType("estimate", _not_an_estimate)


def write_estimate(out: str | Path, split: str, ids: list[str], d1: np.ndarray, depths: FrameDepths, *,
                   plot: str | None = None, title: str = "", overwrite: bool = False) -> None:
    """Write the folder `out`: examples.csv (the estimates, a predictions file) and frames.csv;
    and, with `plot`, the plot titled `title` there, before the folder is moved into place (a
    plot that cannot be written leaves no folder)."""
    if len(ids) != len(d1):
        raise InputError(f"{out}: {len(d1)} estimates for {len(ids)} examples")
    examples = predictions_table(out, zip([split] * len(ids), ids, d1.tolist(), strict=True))
    with atomic_folder(out, ESTIMATE, overwrite=overwrite) as partial:
        examples.to_csv(partial / EXAMPLES, index=False, lineterminator="\n")
        depths.table().to_csv(partial / FRAMES, index=False, lineterminator="\n", na_rep="")
        if plot:
            plot_depths(depths, plot, title, overwrite=overwrite)


def plot_depths(depths: FrameDepths, path: str, title: str, *, overwrite: bool = False) -> None:
    """Draw `depths` over the frame rows (closest first) to `path` (format from its suffix), as
    every output is written (outputs.atomic_file)."""
    fmt = plot_format(path)
    plt = pyplot(NEEDED_BY)
    frames = np.arange(len(depths.median))
    fig, ax = plt.subplots(figsize=(8, 4))
    ax.fill_between(frames, depths.low, depths.high, color="tab:blue", alpha=0.25, lw=0,
                    label="min to max over the windows ending there")
    ax.plot(frames, depths.median, color="tab:blue", lw=1.5, label="estimate (median of the windows)")
    if not np.isnan(depths.truth).all():
        ax.plot(frames, depths.truth, color="black", lw=1, ls="--", label="label (stored depth)")
    ax.set_xlabel("frame (store row, closest first)")
    ax.set_ylabel("depth (m)")
    ax.set_title(title, fontsize=9)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7)
    fig.tight_layout()
    try:
        with atomic_file(path, overwrite=overwrite, option="plot") as partial:
            fig.savefig(partial, dpi=110, format=fmt)
    finally:
        plt.close(fig)
