"""`odms-data train` and `odms-data predict`: ODN (the ODMS paper's network) and DBox (ODMD's),
trained on the stream."""

from __future__ import annotations

import signal
import sys
import time
from pathlib import Path
from typing import Any

import click

from ..errors import InputError
from ..extras import install_line, optional
from ..interrupts import stop_signal
from ..network.variants import VARIANTS
from ..parallel import cores
from ..simulate.box_examples import BOX_PRESETS
from ..simulate.params import PRESETS
from . import echo_json
from .progress import PERIOD, Bars, duration
from .score_commands import DATA_HELP


def _describe(s: Any) -> str:
    if s is None:
        return ""
    text = f"{s.iterations_per_s:.2f} it/s, {s.examples_per_s:,.0f} ex/s, loss {s.loss:.4g}"
    if s.val is not None:
        text += f", val {s.val:.2f}%, best {s.best:.2f}% at {s.best_iteration}"
    return text


def _left(s: Any) -> str:
    """The time left (training.Status.seconds_left: validations included), once it is known."""
    left = s.seconds_left
    return f", about {duration(left)} left" if left else ""


class _TrainProgress:
    """A bar on a terminal; elsewhere (a log file) a line every PERIOD seconds and at the end."""

    def __init__(self, run: str) -> None:
        self.run, self.tty = run, sys.stderr.isatty()
        self.bar: Any = None
        self.status: Any = None
        self.last = -PERIOD

    def __call__(self, s: Any) -> None:
        if self.status is None:
            resumed = f", resuming from iteration {s.started_at} (last.pt)" if s.started_at else ""
            click.echo(f"training {self.run} on {s.device}{resumed}", err=True)
        self.status = s
        if self.tty:
            if self.bar is None:
                self.bar = click.progressbar(length=s.iterations - s.started_at, label="iterations",
                                             file=sys.stderr, show_eta=False,
                                             item_show_func=lambda s: s and _describe(s) + _left(s))
                self.bar.__enter__()
            self.bar.update(1, s)
        elif time.monotonic() - self.last >= PERIOD or s.iteration == s.iterations:
            self.last = time.monotonic()
            click.echo(f"iteration {s.iteration}/{s.iterations}, {duration(s.seconds)} elapsed{_left(s)}: "
                       f"{_describe(s)}", err=True)

    def close(self) -> None:
        if self.bar is not None:
            self.bar.__exit__(None, None, None)


RECIPE = "the model's recipe"  # shown as the default of the options each model's recipe sets


@click.command()
@click.option("--model", type=click.Choice(list(VARIANTS)), default="odn-l", show_default=True,
              help="odn-l learns the relative scale d1/d_n, odn-dbar d1/(z_n - z_1), odn-d d1 (m), from "
                   "masks; dbox the depth over the first camera movement's length, dbox-abs the depth (m), "
                   "from boxes (ODMD's DBox and DBox_Abs).")
@click.option("--radial", is_flag=True, help="Add the radial image as an input (the paper's ODN_lr etc.).")
@click.option("-o", "--output", "run", type=click.Path(), required=True,
              help="Run folder to write; rerunning the same command resumes it from its last checkpoint.")
@click.option("--val", multiple=True, type=click.Path(), required=True,
              help="Validation store (repeatable): the best checkpoint has the lowest mean of their mean "
                   "percent errors.")
@click.option("--iterations", type=click.IntRange(min=1), default=None, show_default=RECIPE,
              help="ODN 5,000, DBox 100,000.")
@click.option("--batch-size", type=click.IntRange(min=1), default=None, show_default=RECIPE,
              help="Freshly generated examples per iteration (512).")
@click.option("--lr", type=click.FloatRange(min=0, min_open=True), default=None, show_default=RECIPE,
              help="Adam's learning rate (1e-3).")
@click.option("--val-every", type=click.IntRange(min=1), default=None, show_default=RECIPE,
              help="Validate (and checkpoint) every this many iterations, and at the last (ODN 10, DBox "
                   "1,000).")
@click.option("--n-obs", type=click.IntRange(min=2), default=10, show_default=True,
              help="Observations the network sees (evenly spaced over each example's).")
@click.option("--preset", type=click.Choice(sorted({*PRESETS, *BOX_PRESETS})), default=None,
              show_default=RECIPE,
              help="Generator preset of the training stream: ODN's standard (perturb: the paper's ODN_*p), "
                   "DBox's odmd (ODMD's released generator).")
@click.option("--seed", type=click.IntRange(min=0), default=0, show_default=True,
              help="Seed of the stream and of the initial weights (not 20200001-20200004: the splits').")
@click.option("--workers", type=click.IntRange(min=0), default=None, show_default="all cores",
              help="Processes generating the stream (0: in this process).")
@click.option("--device", default=None, help="cpu, cuda, cuda:1, ... (default: a GPU when there is one).")
@click.option("--overwrite", is_flag=True, help="Start the run in the folder again from iteration 0.")
@click.option("--json", "as_json", is_flag=True,
              help="Print the run's outcome as JSON (progress stays on stderr).")
@click.pass_context
def train(ctx, model, radial, run, val, iterations, batch_size, lr, val_every, n_obs, preset, seed, workers,
          device, overwrite, as_json):
    """Train ODN or DBox on freshly generated examples with the authors' recipe, into a run folder.

    Adam, L1 loss on the model's label, validation on the --val stores every --val-every
    iterations (best.pt keeps the best weights, last.pt where a rerun resumes), curves in
    curves.csv and curves.png. DBox validates on stores of boxes, or of masks through the box
    rule. Layout and recipes: docs/TRAINING.md.

    \b
    Examples:
      odms-data generate --split sim-val
      odms-data train --model odn-l -o runs/odn-l --val sim-val.zarr
      odms-data train --model odn-l --radial -o runs/odn-lr --val stores/robot-val.zarr \\
          --val stores/driving-val.zarr --val stores/normal-val.zarr --val stores/perturb-val.zarr
      odms-data train --model odn-d -o runs/quick --val sim-val.zarr --iterations 200 --batch-size 64
      odms-data train --model dbox -o runs/dbox --val stores/normal-val.zarr --iterations 20000
    """
    optional("torch", "odms-data train")
    from ..network.curves import draw
    from ..network.run_folder import PLOT, RunFolder, TrainConfig
    from ..network.training import train as run_training

    stores = tuple(str(Path(v).resolve()) if Path(v).exists() else v for v in val)
    config = TrainConfig.recipe(model, radial=radial, n_obs=n_obs, preset=preset, seed=seed,
                                iterations=iterations, batch_size=batch_size, lr=lr, val_every=val_every,
                                val=stores)
    shown = _TrainProgress(run)
    try:
        s = run_training(run, config, workers=cores() if workers is None else workers, device=device,
                         overwrite=overwrite, report=shown)
    except BaseException as e:
        signum = stop_signal(e)  # also a stop a C extension returned as another error
        if signum is None:
            raise
        shown.close()
        at = shown.status.checkpoint if shown.status else 0
        click.echo(f"odms-data: interrupted ({signal.Signals(signum).name}); rerun the same command to "
                   f"resume {run} from its last checkpoint (iteration {at})", err=True)
        ctx.exit(128 + signum)
    shown.close()
    plot = draw(RunFolder(run))
    if as_json:
        echo_json({"run": run, "config": config.to_json(), "iteration": s.iteration, "complete_before":
                   s.started_at >= config.iterations, "best": s.best, "best_iteration": s.best_iteration,
                   "best_per_set": {k: {"percent_error": e, "iteration": i} for k, (e, i) in
                                    s.best_per_set.items()},
                   "seconds": s.seconds, "curves": str(Path(run) / "curves.csv"),
                   "plot": str(Path(run) / PLOT) if plot else None})
        return
    if s.started_at >= config.iterations:
        click.echo(f"{run}: the run is complete ({config.iterations} iterations); --overwrite trains it "
                   "again")
    else:
        click.echo(f"wrote {run}: {config.iterations} iterations of {config.batch_size} examples; best "
                   "validation mean "
                   f"percent error {s.best:.2f} at iteration {s.best_iteration} (best.pt)")
    click.echo(f"curves: {Path(run) / 'curves.csv'}" + (f", {Path(run) / PLOT}" if plot else
               f" (curves.png not drawn: matplotlib is missing; {install_line('plot')})"))


CHECKPOINTS = ("best", "last", "per-set")


@click.command()
@click.argument("run", type=click.Path(), required=False)
@click.option("--data", multiple=True, type=click.Path(), help=DATA_HELP)
@click.option("-o", "--output", type=click.Path(), required=True, help="Predictions CSV to write.")
@click.option("--checkpoint", default="best", show_default=True, metavar="[best|last|per-set|FILE]",
              help="Which of the run's checkpoints predicts; per-set: for each store, the best on the "
                   "validation set of its domain (robot-val's for robot-test), as for the paper's Table 1. "
                   "Or, without RUN, a weights file of --model (ODMD's DBox_pretrained_paper.pt).")
@click.option("--model", type=click.Choice(list(VARIANTS)), default=None,
              help="The network of a --checkpoint FILE (dbox for ODMD's pretrained DBox).")
@click.option("--n-obs", type=click.IntRange(min=2), default=10, show_default=True,
              help="Observations the network of a --checkpoint FILE takes.")
@click.option("--workers", type=click.IntRange(min=0), default=None, show_default="all cores",
              help="Processes reading the stores (0: in this process).")
@click.option("--device", default=None, help="cpu, cuda, cuda:1, ... (default: a GPU when there is one).")
@click.option("--overwrite", is_flag=True, help="Replace an existing predictions file.")
@click.option("--json", "as_json", is_flag=True, help="Print what was written as JSON.")
def predict(run, data, output, checkpoint, model, n_obs, workers, device, overwrite, as_json):
    """Predict d1 for every example of the stores with a trained run; the file `score` reads.

    DBox predicts stores of boxes, and stores of masks through the box rule (docs/ODMD.md): there
    each box is paired with its own camera movement, not as ODMD's converted sets pair them, so
    its figures on the ODMS stores are not those of ODMD's odms_detection sets.

    \b
    Examples:
      odms-data predict runs/odn-l --data ./odms-stores -o odn-l.csv
      odms-data score odn-l.csv --data ./odms-stores
      odms-data predict runs/odn-l --data sim-test.zarr --checkpoint last -o sim.csv
      odms-data predict runs/odn-l --data ./odms-stores --checkpoint per-set -o odn-l-table1.csv
      odms-data predict --model dbox --checkpoint DBox_pretrained_paper.pt --data ./odms-stores -o dbox.csv
    """
    optional("torch", "odms-data predict")
    from ..evaluation.ground_truth import data_locations, find_stores
    from ..network import prediction
    from ..network.run_folder import RunFolder

    workers = cores() if workers is None else workers
    from_file = checkpoint not in CHECKPOINTS
    if from_file and (run is not None or model is None):
        raise InputError(f"--checkpoint {checkpoint}: a weights file predicts without a RUN folder and needs "
                         f"--model; a run's checkpoint is one of {', '.join(CHECKPOINTS)}")
    if not from_file and run is None:
        raise InputError("give the RUN folder to predict with, or --model and --checkpoint FILE")
    if not from_file and model is not None:
        raise InputError("--model goes with --checkpoint FILE; a RUN folder names its own model")
    if not from_file:
        RunFolder(run).config()  # a run folder? (before the stores are opened)
    stores = find_stores(data_locations(data))
    with Bars(f"predicting {{}} with {run or checkpoint}") as bars:
        if from_file:
            rows, config, at = prediction.predict_from_weights(
                checkpoint, model, stores, output, n_obs=n_obs, workers=workers, device=device,
                overwrite=overwrite, progress=bars)
        else:
            rows, config, at = prediction.predict(RunFolder(run), stores, output, which=checkpoint,
                                                  workers=workers, device=device, overwrite=overwrite,
                                                  progress=bars)
    as_boxes = _masks_read_as_boxes(config.model, stores)
    if as_json:
        echo_json({"output": output, "predictions": rows, "model": config.model, "checkpoint": checkpoint,
                   "iterations": at, **({"masks_read_as_boxes": as_boxes} if as_boxes else {})})
        return
    iterations = (f"iteration {next(iter(at.values()))}" if len(set(at.values())) == 1
                  else "iterations " + ", ".join(f"{split} {i}" for split, i in at.items()))
    what = f"{checkpoint}" if from_file else f"{checkpoint} checkpoint, {iterations}"
    click.echo(f"wrote {output}: {rows} predictions of {config.model} ({what}) for "
               f"{', '.join(sorted(stores))}")
    if as_boxes:
        click.echo(f"{', '.join(as_boxes)}: stores of masks, read as boxes (the box rule) each paired with "
                   "its own camera movement, not as ODMD's converted odms_detection sets pair them: these "
                   "are not the authors' figures on those sets (docs/ODMD.md, \"Camera movement pairing\")")


def _masks_read_as_boxes(model: str, stores: dict[str, Path | str]) -> list[str]:
    """The splits of `stores` that DBox-family `model` read as boxes from stores of masks."""
    if VARIANTS[model].family != "dbox":
        return []
    from ..store.reader import open_store

    masks = []
    for split, path in stores.items():
        with open_store(str(path)) as s:
            if s.kind == "masks":
                masks.append(split)
    return sorted(masks)
