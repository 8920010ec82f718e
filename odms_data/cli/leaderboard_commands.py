"""`odms-data leaderboard`."""

from __future__ import annotations

import click

from ..protocol import FAMILIES
from . import echo_json


@click.command()
@click.option("--family", type=click.Choice(FAMILIES), default="test", show_default=True,
              help="Which sets to show.")
@click.option("--metric", type=click.Choice(["percent", "abs"]), default="percent", show_default=True,
              help="Mean percent error or mean absolute error (cm; driving in m).")
@click.option("--dir", "folders", type=click.Path(file_okay=False), multiple=True,
              help="Also rank the entries in this folder, e.g. the one `score --entry` wrote yours to "
                   "(repeatable; the shipped entries are always in).")
@click.option("--benchmark", type=click.Choice(["odms", "odmd"]), default="odms", show_default=True,
              help="ODMS's table, or ODMD's (its sets normal, perturb motion, perturb detection, robot).")
@click.option("--json", "as_json", is_flag=True, help="Print the ranked entries as JSON (all metrics).")
def leaderboard(family, metric, folders, benchmark, as_json):
    """Print the leaderboard as markdown, sorted by All (lowest error first): the entries shipped
    with odms-data and those in each --dir.

    \b
    Examples:
      odms-data leaderboard
      odms-data leaderboard --dir leaderboard       # with the entries `score --entry` wrote there
      odms-data leaderboard --family val --metric abs
      odms-data leaderboard --benchmark odmd
    """
    from ..evaluation.leaderboard import family_all, load_entries, ranked, render_markdown, shipped_folder

    entries = load_entries(shipped_folder(), *folders, benchmark=benchmark)
    if as_json:
        keys = ("name", "n_obs", "training_data", "radial_input", "figures", "link", "citation")
        echo_json([
            {"rank": rank, **{k: getattr(e, k) for k in keys}, "all": family_all(e, family),
             "results": e.results[family]}
            for rank, e in enumerate(ranked(entries, family), 1)])
        return
    click.echo(render_markdown(entries, family, metric, benchmark), nl=False)
