"""`odms-data leaderboard` (the table, or the site with --html) and `odms-data leaderboard verify`."""

from __future__ import annotations

import click

from ..protocol import BENCHMARKS, SPLIT_FAMILIES
from . import echo_json, echo_text
from .progress import Bars

DIR_HELP = ("Also rank the entries in this folder, e.g. the one `score --entry` wrote yours to "
            "(repeatable; the shipped entries are always in).")


@click.group(invoke_without_command=True)
@click.option("--family", type=click.Choice(SPLIT_FAMILIES), default="test", show_default=True,
              help="Which sets to show.")
@click.option("--metric", type=click.Choice(["percent", "abs"]), default="percent", show_default=True,
              help="Mean percent error or mean absolute error (cm; driving in m).")
@click.option("--dir", "folders", type=click.Path(file_okay=False), multiple=True, help=DIR_HELP)
@click.option("--benchmark", type=click.Choice(tuple(BENCHMARKS)), default="odms", show_default=True,
              help="ODMS's table, ODMS-detection's (ODMD's boxes of the ODMS sets) or ODMD's (its sets "
                   "normal, perturb motion, perturb detection, robot).")
@click.option("--json", "as_json", is_flag=True, help="Print the ranked entries as JSON (all metrics).")
@click.option("--html", "site", type=click.Path(), default=None,
              help="Write the leaderboard as a static site to this folder instead: a page per benchmark "
                   "and per entry, self-contained (no external script, font or style).")
@click.option("--overwrite", is_flag=True, help="Replace an earlier --html site.")
@click.option("--data", multiple=True, type=click.Path(),
              help="With --html: folder of ground-truth stores, or one store (repeatable; as for `score`); "
                   "neighbours that both ship predictions then tie when `compare` cannot separate them, "
                   "and their pages show their breakdown plots.")
@click.pass_context
def leaderboard(ctx, family, metric, folders, benchmark, as_json, site, overwrite, data):
    """Print the leaderboard as markdown, sorted by All (lowest error first): the entries shipped
    with odms-data and those in each --dir.

    \b
    Examples:
      odms-data leaderboard
      odms-data leaderboard --dir leaderboard       # with the entries `score --entry` wrote there
      odms-data leaderboard --family val --metric abs
      odms-data leaderboard --benchmark odmd
      odms-data leaderboard --dir leaderboard --html site/   # then open site/index.html
      odms-data leaderboard --dir leaderboard --html site/ --data ./odms-stores  # ties by compare
      odms-data leaderboard verify --data ./odms-stores
    """
    if ctx.invoked_subcommand:
        return
    from ..errors import InputError
    from ..evaluation.leaderboard import entry_files, family_all, ranked, render_markdown, shipped_folder

    if site and as_json:
        raise InputError("give at most one of --html and --json")
    if data and not site:
        raise InputError("--data is for --html (ties decided by compare); give --html DIR too")
    pairs = entry_files(shipped_folder(), *folders)
    if site:
        from ..evaluation.leaderboard_site import write_site
        from ..evaluation.leaderboard_verify import predictions_of

        shipped = {e.name: p for e, p in ((e, predictions_of(path)) for path, e in pairs) if p}
        pages = write_site([e for _, e in pairs], site, overwrite=overwrite, predictions=shipped, data=data)
        click.echo(f"wrote {site}: {len(pages)} pages (open {site}/index.html)", err=True)
        return
    entries = [e for _, e in pairs if e.benchmark == benchmark]
    if as_json:
        keys = ("name", "n_obs", "training_data", "radial_input", "figures", "link", "citation")
        echo_json([
            {"rank": rank, **{k: getattr(e, k) for k in keys}, "all": family_all(e, family),
             "results": e.results[family]}
            for rank, e in enumerate(ranked(entries, family), 1)])
        return
    click.echo(render_markdown(entries, family, metric, benchmark), nl=False)


@leaderboard.command()
@click.option("--dir", "folders", type=click.Path(file_okay=False), multiple=True,
              help="Also verify the entries in this folder (repeatable; the shipped entries are always in).")
@click.option("--data", multiple=True, type=click.Path(),
              help="Folder of ground-truth stores, or one store (repeatable); as for `score`.")
def verify(folders, data):
    """Re-score every computed entry that ships its predictions (the CSV beside the entry, with its
    name: mynet.json, mynet.csv) and say which figures no longer match. Exit code 1 when any
    does not.

    \b
    Examples:
      odms-data leaderboard verify --data ./odms-stores
      odms-data leaderboard verify --dir leaderboard --data ./odms-stores
    """
    from ..evaluation.leaderboard import entry_files, shipped_folder
    from ..evaluation.leaderboard_verify import predictions_of, verify_entry

    pairs = entry_files(shipped_folder(), *folders)
    shipping = [(p, e) for p, e in pairs if e.figures == "computed" and predictions_of(p)]
    failed = 0
    for path, entry in shipping:
        with Bars(f"verifying {entry.name}: {{}}") as bars:
            verdict = verify_entry(path, entry, data, progress=bars)
        failed += bool(verdict.differences)
        if verdict.differences:
            echo_text(f"{entry.name} ({path}): {len(verdict.differences)} figures no longer match")
            for line in verdict.differences:
                echo_text(f"  {line}")
        else:
            echo_text(f"{entry.name} ({path}): all {verdict.figures} figures match")
    echo_text(f"{len(shipping)} entries ship their predictions, {failed} no longer match; "
              f"{len(pairs) - len(shipping)} ship none (published figures, or no CSV beside the entry)")
    if failed:
        raise click.exceptions.Exit(1)
