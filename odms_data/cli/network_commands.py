"""`odms-data train` and `odms-data predict`: ODN, the paper's network, trained on the stream."""

from __future__ import annotations

import os
import signal
import sys
import time
from pathlib import Path
from typing import Any

import click

from ..errors import Interrupted
from ..network.variants import VARIANTS
from ..simulate.params import PRESETS
from .progress import PERIOD, duration, progress
from .score_commands import DATA_HELP


def _describe(s: Any) -> str:
    if s is None:
        return ""
    text = f"{s.iterations_per_s:.2f} it/s, {s.examples_per_s:,.0f} ex/s, loss {s.loss:.4g}"
    if s.val is not None:
        text += f", val {s.val:.2f}%, best {s.best:.2f}% at {s.best_iteration}"
    return text


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
                                             file=sys.stderr, item_show_func=_describe)
                self.bar.__enter__()
            self.bar.update(1, s)
        elif time.monotonic() - self.last >= PERIOD or s.iteration == s.iterations:
            self.last = time.monotonic()
            left = (s.iterations - s.iteration) / s.iterations_per_s if s.iterations_per_s else 0
            click.echo(f"iteration {s.iteration}/{s.iterations}, {duration(s.seconds)} elapsed"
                       + (f", about {duration(left)} left" if left else "") + f": {_describe(s)}", err=True)

    def close(self) -> None:
        if self.bar is not None:
            self.bar.__exit__(None, None, None)


@click.command()
@click.option("--model", type=click.Choice(list(VARIANTS)), default="odn-l", show_default=True,
              help="odn-l learns the relative scale d1/d_n, odn-dbar d1/(z_n - z_1), odn-d d1 (m).")
@click.option("--radial", is_flag=True, help="Add the radial image as an input (the paper's ODN_lr etc.).")
@click.option("-o", "--output", "run", type=click.Path(), required=True,
              help="Run folder to write; rerunning the same command resumes it from its last checkpoint.")
@click.option("--val", multiple=True, type=click.Path(), required=True,
              help="Validation store (repeatable): the best checkpoint has the lowest mean of their mean "
                   "percent errors.")
@click.option("--iterations", type=click.IntRange(min=1), default=5000, show_default=True)
@click.option("--batch-size", type=click.IntRange(min=1), default=512, show_default=True,
              help="Freshly generated examples per iteration.")
@click.option("--lr", type=click.FloatRange(min=0, min_open=True), default=1e-3, show_default=True,
              help="Adam's learning rate.")
@click.option("--val-every", type=click.IntRange(min=1), default=10, show_default=True,
              help="Validate (and checkpoint) every this many iterations, and at the last.")
@click.option("--n-obs", type=click.IntRange(min=2), default=10, show_default=True,
              help="Observations the network sees (evenly spaced over each example's).")
@click.option("--preset", type=click.Choice(sorted(PRESETS)), default="standard", show_default=True,
              help="Generator preset of the training stream (perturb: the paper's ODN_*p).")
@click.option("--seed", type=click.IntRange(min=0), default=0, show_default=True,
              help="Seed of the stream and of the initial weights (not 20200001-20200004: the splits').")
@click.option("--workers", type=click.IntRange(min=0), default=os.cpu_count() or 1, show_default="all cores",
              help="Processes generating the stream (0: in this process).")
@click.option("--device", default=None, help="cpu, cuda, cuda:1, ... (default: a GPU when there is one).")
@click.option("--overwrite", is_flag=True, help="Start the run in the folder again from iteration 0.")
@click.pass_context
def train(ctx, model, radial, run, val, iterations, batch_size, lr, val_every, n_obs, preset, seed, workers,
          device, overwrite):
    """Train ODN on freshly generated examples with the paper's recipe, into a run folder.

    Adam, L1 loss on the model's label, validation on the --val stores every --val-every
    iterations (best.pt keeps the best weights, last.pt where a rerun resumes), curves in
    curves.csv and curves.png. Layout: schemas/TRAINING.md.

    \b
    Examples:
      odms-data generate --split sim-val
      odms-data train --model odn-l -o runs/odn-l --val sim-val.zarr
      odms-data train --model odn-l --radial -o runs/odn-lr --val stores/robot-val.zarr \\
          --val stores/driving-val.zarr --val stores/normal-val.zarr --val stores/perturb-val.zarr
      odms-data train --model odn-d -o runs/quick --val sim-val.zarr --iterations 200 --batch-size 64
    """
    from ..network.curves import draw
    from ..network.run_folder import PLOT, RunFolder, TrainConfig
    from ..network.training import train as run_training

    stores = tuple(str(Path(v).resolve()) if Path(v).exists() else v for v in val)
    config = TrainConfig(model=model, radial=radial, n_obs=n_obs, preset=preset, seed=seed,
                         iterations=iterations, batch_size=batch_size, lr=lr, val_every=val_every, val=stores)
    shown = _TrainProgress(run)
    try:
        s = run_training(run, config, workers=workers, device=device, overwrite=overwrite, report=shown)
    except KeyboardInterrupt as e:
        shown.close()
        at = shown.status.checkpoint if shown.status else 0
        signum = e.signum if isinstance(e, Interrupted) else signal.SIGINT  # exit 128 + the signal
        click.echo(f"odms-data: interrupted ({signal.Signals(signum).name}); rerun the same command to "
                   f"resume {run} from its last checkpoint (iteration {at})", err=True)
        ctx.exit(128 + signum)
    shown.close()
    if s.started_at >= iterations:
        click.echo(f"{run}: the run is complete ({iterations} iterations); --overwrite trains it again")
    else:
        click.echo(f"wrote {run}: {iterations} iterations of {batch_size} examples; best validation mean "
                   f"percent error {s.best:.2f} at iteration {s.best_iteration} (best.pt)")
    plot = draw(RunFolder(run))
    click.echo(f"curves: {Path(run) / 'curves.csv'}" + (f", {Path(run) / PLOT}" if plot else
               " (curves.png not drawn: matplotlib is missing; pip install 'odms-data[plot]')"))


@click.command()
@click.argument("run", type=click.Path())
@click.option("--data", multiple=True, type=click.Path(), help=DATA_HELP)
@click.option("-o", "--output", type=click.Path(), required=True, help="Predictions CSV to write.")
@click.option("--checkpoint", type=click.Choice(["best", "last"]), default="best", show_default=True,
              help="Which of the run's checkpoints predicts.")
@click.option("--workers", type=click.IntRange(min=0), default=os.cpu_count() or 1, show_default="all cores",
              help="Processes reading the stores (0: in this process).")
@click.option("--device", default=None, help="cpu, cuda, cuda:1, ... (default: a GPU when there is one).")
@click.option("--overwrite", is_flag=True, help="Replace an existing predictions file.")
def predict(run, data, output, checkpoint, workers, device, overwrite):
    """Predict d1 for every example of the stores with a trained run; the file `score` reads.

    \b
    Examples:
      odms-data predict runs/odn-l --data ./odms-stores -o odn-l.csv
      odms-data score odn-l.csv --data ./odms-stores
      odms-data predict runs/odn-l --data sim-test.zarr --checkpoint last -o sim.csv
    """
    from ..evaluation.ground_truth import data_locations, find_stores
    from ..network.prediction import predict as run_prediction
    from ..network.run_folder import RunFolder
    from ..store.reader import open_store

    folder = RunFolder(run)
    folder.config()  # a run folder? (before the stores are opened)
    stores = find_stores(data_locations(data))
    total = 0
    for path in stores.values():
        with open_store(str(path)) as s:
            total += len(s)
    with progress(total, f"predicting with {run}") as update:
        rows, config, at = run_prediction(folder, stores, output, which=checkpoint, workers=workers,
                                          device=device, overwrite=overwrite, progress=update)
    click.echo(f"wrote {output}: {rows} predictions of {config.model} ({checkpoint} checkpoint, "
               f"iteration {at}) for {', '.join(sorted(stores))}")
