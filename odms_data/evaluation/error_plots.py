"""The error plot (`odms-data score --plot`): percent error against true depth, one panel per split,
then the mean percent error per depth bin and per motion bin (breakdown.py's groups), one panel per
split (each split is one domain)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from ..errors import InputError
from ..extras import pyplot
from ..outputs import atomic_file
from .breakdown import groups_of
from .scoring import ScoreReport

NEEDED_BY = "the error plot"  # what needs matplotlib, in its error
LINEAR_BELOW = 10  # percent: the y axis is symlog, linear up to here so that 0 shows
TICKS = [0, 2, 5] + [m * 10**k for k in range(1, 7) for m in (1, 2, 5)]  # labelled percent errors


def plot_format(path: str) -> str:
    """The file format matplotlib writes for `path`'s suffix; InputError when it has none it knows
    (matplotlib would otherwise add `.png` to the name)."""
    pyplot(NEEDED_BY)
    from matplotlib.backend_bases import FigureCanvasBase

    known = FigureCanvasBase.get_supported_filetypes()
    suffix = Path(path).suffix.lower().lstrip(".")
    if suffix not in known:
        what = f"suffix .{suffix} is not an image format matplotlib writes" if suffix else "has no suffix"
        raise InputError(f"plot {path}: {what}; name it e.g. errors.png "
                         f"({', '.join('.' + k for k in sorted(known))})", option="plot")
    return suffix


def _binned_panel(ax, report: ScoreReport, split: str, key: str) -> None:
    """Mean percent error per bin of `key` (depth or motion) of one split, with each bin's n."""
    truth = report.truths[split]
    idx = report.scored[split][0]
    which, names = groups_of(truth, idx, key)
    pe = report.errors[split][1]
    kept = [b for b in range(len(names)) if (which == b).any()]
    means = [float(pe[which == b].mean()) for b in kept]
    ax.bar(range(len(kept)), means, color="tab:blue" if key == "depth" else "tab:orange")
    ticks = [f"{names[b].removesuffix(' m')}\nn={int((which == b).sum())}" for b in kept]
    ax.set_xticks(range(len(kept)), ticks, fontsize=6)
    ax.set_title(f"{split}: mean % error by {'true depth d1' if key == 'depth' else 'camera travel'} (m)",
                 fontsize=8)
    ax.set_ylabel("mean percent error")
    ax.grid(alpha=0.3, axis="y")


def plot_errors(report: ScoreReport, path: str, *, overwrite: bool = False) -> None:
    """Scatter of each example's percent error against its true depth d1, with the binned median,
    written to `path` (format from its suffix) as every output is (outputs.atomic_file)."""
    fmt = plot_format(path)
    plt = pyplot(NEEDED_BY)
    from matplotlib import ticker

    splits = [s for s in report.scores if s.split in report.errors]
    cols = min(4, len(splits))
    rows = math.ceil(len(splits) / cols)
    fig, grid = plt.subplots(3 * rows, cols, figsize=(4.2 * cols, 3.4 * 3 * rows), squeeze=False)
    axes = grid[:rows]
    for key, block in (("depth", grid[rows:2 * rows]), ("motion", grid[2 * rows:])):
        for ax, s in zip(block.flat, splits, strict=False):
            _binned_panel(ax, report, s.split, key)
        for ax in list(block.flat)[len(splits):]:
            ax.set_visible(False)
    for ax, s in zip(axes.flat, splits, strict=False):
        truth, pe = report.errors[s.split]
        ax.scatter(truth, pe, s=3, alpha=0.35, linewidths=0)
        edges = np.quantile(truth, np.linspace(0, 1, 11))
        which = np.clip(np.searchsorted(edges, truth, side="right") - 1, 0, 9)
        centres = [truth[which == b].mean() for b in range(10) if (which == b).any()]
        medians = [np.median(pe[which == b]) for b in range(10) if (which == b).any()]
        ax.plot(centres, medians, color="black", lw=1.5, label="median (depth deciles)")
        ax.set_yscale("symlog", linthresh=LINEAR_BELOW)
        ax.yaxis.set_major_locator(ticker.FixedLocator(TICKS))
        ax.yaxis.set_major_formatter(ticker.FuncFormatter(lambda v, _: f"{v:g}"))
        ax.set_title(f"{s.split}: mean {s.mean_percent_error:.1f}%  (n={s.n})", fontsize=9)
        ax.set_xlabel("true depth d1 (m)")
        ax.set_ylabel(f"percent error (linear to {LINEAR_BELOW}, log above)")
        ax.grid(alpha=0.3)
    for ax in list(axes.flat)[len(splits):]:
        ax.set_visible(False)
    axes.flat[0].legend(fontsize=7, loc="upper right")
    title = f"{report.predictions}" + ("  (PARTIAL)" if report.partial else "")
    fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    with atomic_file(path, overwrite=overwrite, option="plot") as partial:
        fig.savefig(partial, dpi=110, format=fmt)
    plt.close(fig)
