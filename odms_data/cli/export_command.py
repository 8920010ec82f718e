"""`odms-data export`."""

from __future__ import annotations

import click

from ..extras import optional
from . import echo_json, echo_text
from .progress import Bars


@click.command()
@click.argument("stores", nargs=-1, required=True, type=click.Path())
@click.option("-o", "--output", type=click.Path(), required=True, help="Folder to write (the dataset).")
@click.option("--name", default=None, help="The dataset's title (default: the output folder's name).")
@click.option("--license", "licence", default=None, metavar="ID",
              help="The Hub's licence id, e.g. cc-by-4.0 (default: mit for generated data, the release's "
                   "research-only licence for the official splits; required for other data).")
@click.option("--examples-per-file", type=click.IntRange(min=1), default=1000, show_default=True,
              help="Examples per Parquet file.")
@click.option("--overwrite", is_flag=True, help="Replace an earlier export at OUTPUT.")
@click.option("--json", "as_json", is_flag=True, help="Print what was written as JSON.")
def export(stores, output, name, licence, examples_per_file, overwrite, as_json):
    """Export stores as a Hugging Face Hub dataset: Parquet shards, a dataset card and Croissant.

    One split per store; `datasets.load_dataset(OUTPUT)` reads it, and the folder can be pushed
    to the Hub as it is. The stores are all of masks or all of boxes (ODMD's kind), whose columns
    differ. Needs pip install 'odms-data[hub]' (pyarrow).

    \b
    Examples:
      odms-data export sim-val.zarr sim-test.zarr -o odms-sim
      odms-data export stores/*-val.zarr -o odms-val --name "ODMS validation"
      odms-data export boxes-val.zarr -o odmd-boxes      # from generate --boxes odmd
    """
    optional("pyarrow", "odms-data export")  # before the stores are read
    from ..publish.hub_export import export_hub

    with Bars("exporting to {}") as bars:
        exported = export_hub(stores, output, name=name, licence=licence, examples_per_file=examples_per_file,
                              overwrite=overwrite, progress=bars)
    if as_json:
        echo_json({"output": output, "splits": [
            {"split": e.split, "examples": e.examples, "files": e.files, "bytes": e.bytes} for e in exported
        ]})
        return
    for e in exported:
        echo_text(f"{e.split}: {e.examples} examples in {len(e.files)} Parquet file(s), {e.bytes:,} bytes")
    click.echo(f"wrote {output}: README.md (dataset card), croissant.json, data/")
