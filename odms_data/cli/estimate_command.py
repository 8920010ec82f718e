"""`odms-data estimate`: a recording's store to the object's depth at every frame, with a baseline
(VOS-DE, Box_LS), DBox's weights or a trained run."""

from __future__ import annotations

from pathlib import Path

import click
import numpy as np

from ..errors import InputError
from ..outputs import check_replaceable
from ..store.oddity import skipped_details
from ..store.reader import Store, open_store
from . import completion, echo_json, echo_text
from .progress import Bars, progress

METHODS = ("vosde", "box-ls", "dbox", "run")
NETWORKS = ("dbox", "run")  # the methods that take --checkpoint


def _check_options(method: str, checkpoint: str | None, n_obs: int | None, output: str, plot: str | None,
                   overwrite: bool) -> None:
    """The options' own problems, before anything is read or computed."""
    from ..evaluation.frame_depths import ESTIMATE

    if method in NETWORKS and checkpoint is None:
        what = "the run folder" if method == "run" else "DBox's weights (ODMD's DBox_pretrained_paper.pt)"
        raise InputError(f"--method {method} needs --checkpoint: {what}")
    if method not in NETWORKS and checkpoint is not None:
        raise InputError(f"--checkpoint goes with --method dbox (a weights file) or run (a run folder), not "
                         f"{method}")
    if method == "run" and n_obs is not None:
        raise InputError("--n-obs: a run's network takes the observations it was trained with")
    check_replaceable(output, overwrite, ESTIMATE, option="output")
    if plot:
        from ..evaluation.error_plots import plot_format
        from ..extras import pyplot

        pyplot("odms-data estimate --plot")
        if Path(plot).absolute() == Path(output).absolute():
            raise InputError(f"--plot and --output both name {plot}; give two paths")
        check_replaceable(plot, overwrite, option="plot")
        plot_format(plot)


def _baseline(store: Store, method: str, n_obs: int | None) -> tuple[np.ndarray, np.ndarray]:
    """(d1, unsolvable) of every example of `store` by a baseline; n_obs None: every observation
    of the example with the fewest."""
    from ..evaluation.box_ls import box_ls
    from ..evaluation.vosde import vosde

    if method == "vosde" and store.kind != "masks":
        raise InputError(f"{store.path}: VOS-DE reads masks and this store holds {store.kind}; use --method "
                         "box-ls or dbox")
    n = int(store.n_obs.min()) if n_obs is None else n_obs
    r = vosde(store, n) if method == "vosde" else box_ls(store, n)
    return r.d1, r.unsolvable


def _network(path: str, method: str, checkpoint: str, n_obs: int | None, workers: int, device: str | None
             ) -> tuple[np.ndarray, str]:
    """The depths a network predicts for the store's examples, and what predicted them."""
    from ..extras import optional

    optional("torch", "odms-data estimate --method " + method)
    from ..network.models import model_of
    from ..network.prediction import load_trained, load_weights, predict_store
    from ..network.run_folder import RunFolder
    from ..network.runtime import pick_device

    dev = pick_device(device)
    if method == "run":
        loaded = load_trained(RunFolder(checkpoint), "best", dev)
    else:
        loaded = load_weights(checkpoint, "dbox", 10 if n_obs is None else n_obs, dev)
    net, config, at = loaded
    with Bars(f"estimating {{}} with {checkpoint}") as bars:
        d1 = predict_store(net, model_of(config), path, dev, workers, bars)[2]
    best = f" (best checkpoint, iteration {at})" if method == "run" else ""
    return d1, f"{config.model}, {checkpoint}{best}"


def _score(store: str, examples: Path, as_json: bool) -> dict:
    """The score of the estimates against the store's labels, printed unless `as_json`."""
    from ..evaluation.evaluate import Evaluation
    from ..evaluation.score_tables import render_text

    _, report = Evaluation([store]).score(examples, intervals=False)
    if not as_json:
        echo_text(render_text(report), nl=False)
    return report.to_json()


@click.command()
@click.argument("store", type=click.Path(), shell_complete=completion.stores)
@click.option("--method", type=click.Choice(METHODS), required=True,
              help="vosde (masks) and box-ls (masks or boxes): the baselines; dbox: DBox's weights file as "
                   "--checkpoint; run: a trained run's folder as --checkpoint (its best checkpoint).")
@click.option("--checkpoint", type=click.Path(), metavar="FILE|RUN-FOLDER",
              help="The weights file of --method dbox, or the run folder of --method run.")
@click.option("--n-obs", type=click.IntRange(min=2), default=None,
              help="Observations used per window, evenly spaced (vosde, box-ls: default all those of the "
                   "window with the fewest; dbox: default 10; a run takes its own).")
@click.option("-o", "--output", type=click.Path(), required=True,
              help="Folder to write: examples.csv (a predictions file) and frames.csv (the depth per frame).")
@click.option("--plot", type=click.Path(), help="Also draw the depth over the frames to this PNG.")
@click.option("--workers", type=click.IntRange(min=0), default=0, show_default=True,
              help="Processes reading the store for a network (0: in this process).")
@click.option("--device", default=None,
              help="A network's device: cpu, cuda, ... (default: a GPU when there is one).")
@click.option("--overwrite", is_flag=True, help="Replace an existing output folder and plot.")
@click.option("--json", "as_json", is_flag=True, help="Print what was written, and the score, as JSON.")
def estimate(store, method, checkpoint, n_obs, output, plot, workers, device, overwrite, as_json):
    """The object's depth at every frame of a recording's STORE (`import recording` or
    `import detections`).

    Each window of the robot protocol estimates the depth at its closest frame, where the
    approaching camera ends it; a frame's depth is the median of the windows ending there, with
    their minimum and maximum (frames.csv: frame, z, true_depth, windows, unsolvable,
    depth_median, depth_min, depth_max; frames are the recording's, closest first; other stores of
    boxes give a row per window's frame). examples.csv
    holds every window's estimate as a predictions file. Where the store has labels, the score
    is printed. Windows the import refused (turning past --max-rotation) are listed.
    docs/ESTIMATE.md has the details.

    \b
    Examples:
      python examples/rendered_scene.py -o scene
      odms-data import recording scene/masks --poses scene/poses.txt --d1 0.3 \\
          --windows 10,15,20,25,30 -o scene.zarr
      odms-data estimate scene.zarr --method vosde -o scene-depth --plot scene-depth.png
      odms-data estimate scene.zarr --method box-ls --n-obs 5 -o scene-box-ls
      odms-data estimate scene.zarr --method dbox --checkpoint DBox_pretrained_paper.pt -o scene-dbox
      odms-data estimate scene.zarr --method run --checkpoint runs/odn-l -o scene-odn
      odms-data import detections scene/boxes_mot.txt --track 1 --image-size 640x480 \\
          --poses scene/trajectory.txt --fps 30 --d1 0.3 --windows 10,15,20,25,30 -o boxes.zarr
      odms-data estimate boxes.zarr --method box-ls -o boxes-depth
    """
    from ..evaluation.frame_depths import EXAMPLES, FRAMES, frame_depths, write_estimate

    _check_options(method, checkpoint, n_obs, output, plot, overwrite)
    with open_store(str(store)) as s:
        split, ids, skipped = s.attrs.split, s.example_ids, skipped_details(s.attrs.oddities)
        labelled = s.attrs.counts["labelled"] > 0
        if method in NETWORKS:
            d1, how = _network(str(store), method, checkpoint, n_obs, workers, device)
            unsolvable = np.zeros(len(d1), bool)
        else:
            with progress(1, f"{method} over {len(ids)} windows", notice=f"estimating {len(ids)} windows "
                          f"with {method}") as update:
                d1, unsolvable = _baseline(s, method, n_obs)
                update(1)
            how = method
        depths = frame_depths(s, d1, unsolvable)
    write_estimate(output, split, ids, d1, depths, plot=plot, title=f"{split}: {how}", overwrite=overwrite)
    report = _score(str(store), Path(output) / EXAMPLES, as_json) if labelled else None
    frames, solved = len(depths.windows), int((depths.windows > 0).sum())
    if as_json:
        echo_json({"output": output, "examples": str(Path(output) / EXAMPLES),
                   "frames": str(Path(output) / FRAMES),
                   "method": how, "windows": len(ids), "unsolvable": int(unsolvable.sum()),
                   "frame_rows": frames, "frames_with_depth": solved, "left_out_at_import": skipped,
                   "plot": plot, "score": report})
        return
    if skipped:
        echo_text(f"left out when {store} was imported, {len(skipped)}:")
        for detail in skipped:
            echo_text(f"  {detail}")
    echo_text(f"wrote {output}: {len(ids)} windows ({int(unsolvable.sum())} unsolvable) in {EXAMPLES}, "
              f"{frames} frames ({solved} with a depth) in {FRAMES} ({how})")
    if plot:
        echo_text(f"wrote {plot}")
