"""`odms-data score`, `odms-data compare` and `odms-data baseline vosde | box-ls`."""

from __future__ import annotations

import json
from pathlib import Path

import click

from ..errors import InputError
from ..evaluation.box_ls import DEFAULT_N_OBS as BOX_LS_N_OBS
from ..evaluation.ground_truth import (
    DEFAULT_DATA,
    ENV_VAR,
)
from ..evaluation.vosde import DEFAULT_N_OBS
from ..outputs import check_replaceable, write_text
from . import completion, echo_json, echo_text
from .progress import Bars, progress

DATA_HELP = (f"Folder of ground-truth stores, or one store (repeatable). Default: ${ENV_VAR} "
             f"(folders separated by ':'), else {DEFAULT_DATA}.")


@click.command()
@click.argument("predictions", type=click.Path())
@click.option("--data", multiple=True, type=click.Path(), help=DATA_HELP)
@click.option("--json", "as_json", is_flag=True, help="Print the scores as JSON.")
@click.option("--markdown", is_flag=True, help="Print the scores as a markdown table.")
@click.option("--allow-partial", is_flag=True,
              help="Score only the examples present (local use; flagged loudly, no All, no entry).")
@click.option("--metrics", "with_metrics", is_flag=True,
              help="Also show AbsRel, SqRel, RMSE, RMSE log, the delta shares, the shares within 5/10/25 % "
                   "and the 90th/95th percentiles of percent error (always in --json; docs/SCORING.md).")
@click.option("--by", "by", type=click.Choice(["depth", "motion", "window", "object", "sequence", "n-obs"]),
              help="Also give the figures per group of each split: depth and motion bins (the benchmark's), "
                   "window length, object, recorded sequence, observations.")
@click.option("--ci", is_flag=True,
              help="Also show each mean's 95 % interval (cluster bootstrap; always in --json).")
@click.option("--plot", type=click.Path(), help="Also draw percent error against true depth to this PNG.")
@click.option("--entry", type=click.Path(), help="Also write a leaderboard entry (JSON) to this file.")
@click.option("--name", help="Method name for --entry.")
@click.option("--citation", help="Citation for --entry.")
@click.option("--link", help="Link (http/https) for --entry.")
@click.option("--n-obs", type=click.IntRange(min=2), help="Observations per example used (for --entry).")
@click.option("--overwrite", is_flag=True, help="Replace existing --plot and --entry files.")
def score(predictions, data, as_json, markdown, allow_partial, with_metrics, by, ci, plot, entry, name,
          citation, link, n_obs, overwrite):
    """Score a predictions file (schemas/PREDICTIONS.md) against the ground-truth stores.

    Per split: n, mean and median percent error, mean absolute error; each benchmark's All per
    family (val, test) when all its sets (ODMS: robot, driving, normal, perturb) are scored in
    full. --json adds the depth metrics and every mean's 95 % interval. Exit code 2 with a
    one-line message when the file is malformed or does not cover its splits.

    \b
    Examples:
      odms-data score preds.csv --data ./odms-stores
      odms-data score preds.csv --metrics --ci
      odms-data score preds.csv --by depth --ci
      odms-data score preds.csv --markdown --plot errors.png
      odms-data score preds.csv --name MyNet --entry leaderboard/mynet.json
    """
    from ..evaluation.evaluate import Evaluation
    from ..evaluation.leaderboard import entry_from_report

    if as_json and markdown:
        raise InputError("give at most one of --json and --markdown")
    if bool(entry) != bool(name):
        raise InputError("--entry and --name go together: --name NAME --entry OUT.json")
    if plot and entry and Path(plot).absolute() == Path(entry).absolute():
        raise InputError(f"--plot and --entry both name {plot}; give two files")
    if plot:
        from ..evaluation.error_plots import plot_format
        from ..extras import pyplot

        pyplot("odms-data score --plot")  # matplotlib is there, said with the command's name
        check_replaceable(plot, overwrite, option="plot")
        plot_format(plot)  # before scoring: matplotlib is there and knows the suffix
    if entry:
        check_replaceable(entry, overwrite, option="entry", suffixes=(".json",))
    with Bars("verifying {}") as bars:  # the digests an entry records, checked first
        preds, report = Evaluation(data).score(predictions, allow_partial=allow_partial, verify=bool(entry),
                                               progress=bars, n_obs=n_obs)
    _show_score(report, by, "json" if as_json else "markdown" if markdown else "text", with_metrics, ci)
    if plot:
        from ..evaluation.error_plots import plot_errors

        plot_errors(report, plot, overwrite=overwrite)
        click.echo(f"wrote {plot}", err=True)
    if entry:
        e = entry_from_report(report, name, citation=citation, link=link, n_obs=n_obs,
                              predictions_sha256=preds.sha256)
        write_text(entry, json.dumps(e.to_json(), indent=2, ensure_ascii=False, allow_nan=False) + "\n",
                   overwrite=overwrite, option="entry")
        click.echo(f"wrote {entry}", err=True)


@click.command()
@click.argument("a", type=click.Path())
@click.argument("b", type=click.Path())
@click.option("--data", multiple=True, type=click.Path(), help=DATA_HELP)
@click.option("--json", "as_json", is_flag=True, help="Print the comparison as JSON.")
def compare(a, b, data, as_json):
    """Compare two predictions files of the same examples, paired example by example.

    Per split and per All: each file's mean percent error, the difference A - B, its 95 %
    paired cluster-bootstrap interval and a sign-flip p-value over recorded sequences
    (docs/SCORING.md); then, in words, which is better where, or that the data cannot tell
    them apart. Two files that do not cover the same examples are refused.

    \b
    Examples:
      odms-data compare vosde.csv box_ls.csv --data ./odms-stores
      odms-data compare mine.csv vosde.csv --json
    """
    from ..evaluation.compare import render_text
    from ..evaluation.evaluate import Evaluation

    result = Evaluation(data).compare(a, b)
    if as_json:
        echo_json(result.to_json())
    else:
        echo_text(render_text(result), nl=False)


def _show_score(report, by, how, metrics, ci):
    """Print the score (`how`: json, markdown or text) and, with `by`, its breakdown."""
    from ..evaluation.breakdown import breakdown
    from ..evaluation.score_tables import breakdown_markdown, breakdown_text, render_text, report_markdown

    groups = breakdown(report, by) if by else []
    if how == "json":
        extra = {"breakdown": {"by": by, "groups": [g.to_json() for g in groups]}} if by else {}
        echo_json({**report.to_json(), **extra})
        return
    markdown = how == "markdown"
    table, parts = (report_markdown, breakdown_markdown) if markdown else (render_text, breakdown_text)
    echo_text(table(report, metrics=metrics, ci=ci), nl=False)
    if by:
        echo_text("\n" + parts(groups, by, metrics=metrics, ci=ci), nl=False)


@click.group()
def baseline():
    """Run a baseline method over stores and write its predictions file."""


@baseline.command()
@click.argument("stores", nargs=-1, shell_complete=completion.stores_or_splits)
@click.option("--data", multiple=True, type=click.Path(), help=DATA_HELP)
@click.option("--n-obs", type=click.IntRange(min=2), default=DEFAULT_N_OBS, show_default=True,
              help="Observations used per example (evenly spaced when an example has more).")
@click.option("-o", "--output", type=click.Path(), required=True, help="Predictions CSV to write.")
@click.option("--overwrite", is_flag=True, help="Replace an existing predictions file.")
@click.option("--json", "as_json", is_flag=True, help="Print the per-store counts as JSON.")
def vosde(stores, data, n_obs, output, overwrite, as_json):
    """VOS-DE (WACV 2020), the ODMS baseline, from the stored mask statistics.

    STORES are split names (looked up in the data folders) or store paths; none means every
    store in the data folders. An example whose least-squares system is singular (e.g. all
    masks empty) is unsolvable and predicts 0, as the authors' code does; the counts are printed.

    \b
    Examples:
      odms-data baseline vosde --data ./odms-stores -o vosde.csv
      odms-data baseline vosde robot-test driving-test --n-obs 5 -o vosde5.csv
      odms-data baseline vosde sim-val.zarr -o sim.csv && odms-data score sim.csv --data sim-val.zarr
    """
    from ..evaluation.vosde import vosde

    _baseline(stores, data, output, overwrite, as_json, "VOS-DE", lambda s: vosde(s, n_obs),
              {"n_obs": n_obs}, "an empty mask", f"n = {n_obs}")


@baseline.command("box-ls")
@click.argument("stores", nargs=-1, shell_complete=completion.stores_or_splits)
@click.option("--data", multiple=True, type=click.Path(), help=DATA_HELP)
@click.option("--n-obs", type=click.IntRange(min=2), default=BOX_LS_N_OBS, show_default=True,
              help="Observations used per example (evenly spaced when an example has more).")
@click.option("--odmd-conversion", is_flag=True,
              help="Read the masks as ODMD's converted ODMS sets do (far-to-near order, robot windows "
                   "from the far end, ODMD's camera-movement pairing); see docs/ODMD.md.")
@click.option("-o", "--output", type=click.Path(), required=True, help="Predictions CSV to write.")
@click.option("--overwrite", is_flag=True, help="Replace an existing predictions file.")
@click.option("--json", "as_json", is_flag=True, help="Print the per-store counts as JSON.")
def box_ls(stores, data, n_obs, odmd_conversion, output, overwrite, as_json):
    """Box_LS (CVPR 2021), ODMD's least-squares baseline, from the boxes of the stored masks.

    Each frame's box is ODMD's: the largest 8-connected region of its mask. STORES are split
    names (looked up in the data folders) or store paths; none means every store in the data
    folders. A zero-width box is a missing detection and takes the nearest observation's box; an
    example with no solvable system predicts 0, as the authors' code does; the counts are printed.

    \b
    Examples:
      odms-data baseline box-ls --data ./odms-stores -o box_ls.csv
      odms-data baseline box-ls robot-test --odmd-conversion -o box_ls_odmd.csv
      odms-data baseline box-ls sim-val.zarr -o sim.csv && odms-data score sim.csv --data sim-val.zarr
    """
    from ..evaluation.box_ls import box_ls as box_ls_of

    how = ", ODMD's conversion" if odmd_conversion else ""
    settings = {"n_obs": n_obs, "odmd_conversion": odmd_conversion}
    _baseline(stores, data, output, overwrite, as_json, "Box_LS", lambda s: box_ls_of(s, **settings),
              settings, "a missing detection", f"n = {n_obs}{how}")


def _baseline(stores, data, output, overwrite, as_json, name, method, settings, flagged, how):
    """Run baseline `method` (`name`) over the stores and print its counts: as JSON (`settings`
    after the output), or a line per store (`flagged`: what one such observation is) and the file's
    (`how`: the run's settings)."""
    from ..evaluation.evaluate import Evaluation

    check_replaceable(output, overwrite, option="output", suffixes=(".csv",))
    evaluation = Evaluation(data)
    paths = evaluation.stores(stores)
    with progress(len(paths), f"{name} (stores)") as update:
        n_rows, counts = evaluation.baseline(paths, output, method, overwrite=overwrite, progress=update)
    if as_json:
        echo_json({"output": output, **settings, "predictions": n_rows,
                   "splits": [c.to_json() for c in counts]})
        return
    for c in counts:
        echo_text(f"{c.split}: {c.examples} examples, {c.unsolvable} unsolvable (predicted 0), "
                  f"{c.ill_conditioned} ill-conditioned, {c.flagged} with {flagged} among the used "
                  "observations")
    click.echo(f"wrote {output}: {n_rows} predictions ({name}, {how})")
