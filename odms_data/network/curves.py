"""curves.png of a run: L1 loss and mean percent error against the iteration, training and validation."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from ..errors import MissingExtraError
from ..extras import pyplot
from ..outputs import replaced_via_partial
from .run_folder import CURVES, PLOT, TRAIN, VAL, RunFolder, read_curves

SMOOTH = 25  # training batches averaged into one point of the training curve
PERCENT_NOTE = ("Percent error has no upper bound: a depth predicted 3 times too far is 200 % off, so an "
                "untrained network's training error runs into the hundreds; it falls as the network learns "
                "the scale.")


def _moving_mean(y: np.ndarray, k: int) -> np.ndarray:
    return np.convolve(y, np.ones(k) / k, mode="valid")


def draw(folder: RunFolder) -> Path | None:
    """Draw RUN/curves.png from RUN/curves.csv; None when matplotlib is not installed."""
    try:
        plt = pyplot("curves.png")
    except MissingExtraError:
        return None
    fig = figure(folder)
    path = folder.file(PLOT)
    with replaced_via_partial(path) as partial:
        fig.savefig(partial, format="png", dpi=110)
    plt.close(fig)
    return path


def figure(folder: RunFolder) -> Any:
    """The matplotlib figure of curves.png: validations as points (joined, so each is visible
    even when there are two), the training batches as a smoothed line."""
    plt = pyplot("curves.png")
    rows = read_curves(folder.file(CURVES))
    config = folder.config()
    sets = list(dict.fromkeys(r["set"] for r in rows))
    stores = [name for name in sets if name not in (TRAIN, VAL)]
    if len(stores) == 1:  # the mean is that store's own curve
        sets.remove(stores[0])
    fig, axes = plt.subplots(1, 2, figsize=(11, 4))
    for ax, column, title in zip(axes, ("loss", "percent_error"), ("L1 loss", "mean percent error of d1"),
                                 strict=True):
        for name in sets:
            its = np.array([int(r["iteration"]) for r in rows if r["set"] == name])
            ys = np.array([float(r[column]) for r in rows if r["set"] == name])
            if name == TRAIN:
                k = max(1, min(SMOOTH, len(ys)))
                ax.plot(its, ys, color="0.8", linewidth=0.5)
                ax.plot(its[k - 1:], _moving_mean(ys, k), color="0.3",
                        label=f"training batches ({k}-batch mean)")
            else:
                mean = "validation: " + (stores[0] if len(stores) == 1 else "mean of the stores")
                label = f"{mean} ({len(ys)} validations)" if name == VAL else name
                ax.plot(its, ys, marker="o", markersize=3, linewidth=2 if name == VAL else 1, label=label)
        ax.set_yscale("log")
        ax.set_xlabel("iteration")
        ax.set_title(title)
        ax.grid(True, which="both", alpha=0.3)
    axes[1].legend(fontsize=8)
    axes[1].set_ylabel("100 |predicted d1 - d1| / d1  (%)")
    fig.text(0.005, 0.01, PERCENT_NOTE, fontsize=7, color="0.35")
    fig.suptitle(f"{config.model}{' + radial' if config.radial else ''}, n = {config.n_obs}, "
                 f"batch {config.batch_size}, lr {config.lr:g}, {config.preset} stream seed {config.seed}")
    fig.tight_layout(rect=(0, 0.05, 1, 1))
    return fig
