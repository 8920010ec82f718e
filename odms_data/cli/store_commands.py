"""`odms-data validate`, `info`, `convert` and `show`."""

from __future__ import annotations

import click
import numpy as np

from ..outputs import check_replaceable
from ..store.reader import open_store
from . import completion, echo_json, echo_text
from .progress import Bars


def _several(reports: list[dict]) -> dict:
    """The JSON of one store's report, or of several: {"stores": [report, ...]}."""
    return reports[0] if len(reports) == 1 else {"stores": reports}


@click.command()
@click.argument("stores", nargs=-1, required=True, type=click.Path(), shell_complete=completion.stores)
@click.option("--json", "as_json", is_flag=True,
              help='Print the report as JSON (several stores: {"stores": [report, ...]}).')
def validate(stores, as_json):
    """Check stores: attributes, shapes, invariants, statistics and content digest.

    Exit code 0 when every store is valid, 1 when problems were found in any.

    \b
    Example:
      odms-data validate sim-val.zarr
      odms-data validate odms-stores/*.zarr
    """
    from ..store.validate import validate as validate_store

    reports = []
    with Bars("validating {}") as bars:
        for store in stores:
            reports.append(validate_store(store, bars))
    if as_json:
        echo_json(_several([{"path": r.path, "ok": r.ok, "problems": r.problems, "warnings": r.warnings,
                             "digest": r.digest} for r in reports]))
    else:
        for store, report in zip(stores, reports, strict=True):
            for w in report.warnings:
                echo_text(f"warning: {store}: {w}")
            for p in report.problems:
                echo_text(f"problem: {store}: {p}")
            echo_text(f"{store}: {'valid' if report.ok else 'INVALID'}"
                      + (f", digest {report.digest}" if report.digest else ""))
    if not all(r.ok for r in reports):
        raise click.exceptions.Exit(1)


EMPTY = {"masks": ("empty_masks", "empty masks"), "boxes": ("missed_detections", "missed boxes")}


@click.command()
@click.argument("stores", nargs=-1, required=True, type=click.Path(), shell_complete=completion.stores)
@click.option("--json", "as_json", is_flag=True,
              help='Print the attributes and summary as JSON (several stores: {"stores": [summary, ...]}).')
def info(stores, as_json):
    """Summarise stores: split, domain, counts, observations, depth range, generator.

    \b
    Example:
      odms-data info sim-val.zarr
      odms-data info odms-stores/*.zarr
    """
    summaries = [_summary(store) for store in stores]
    if as_json:
        echo_json(_several([summary for summary, _ in summaries]))
        return
    echo_text("\n\n".join(text for _, text in summaries))


def _summary(store: str) -> tuple[dict, str]:
    """One store's summary, as JSON and as text."""
    with open_store(store) as s:
        a = s.attrs
        empty_key, empty_text = EMPTY[s.kind]
        n_obs, d1 = s.n_obs, s.d1[~np.isnan(s.d1)]
        summary = {
            "path": store, "format": s.format, **a.to_json(),
            "observations": {"min": int(n_obs.min()), "max": int(n_obs.max())},
            "d1": {"min": float(d1.min()), "max": float(d1.max())} if len(d1) else None,
            empty_key: int(s.empty_frames.sum()),
            "example_ids": {"first": s.example_ids[0], "last": s.example_ids[-1]} if len(s) else None,
        }
    gen = a.generator
    lines = [
        f"store       {store} ({s.format}, format version {a.format_version})",
        f"split       {a.split} (domain {a.domain})",
        f"examples    {a.counts['examples']} ({a.counts['labelled']} labelled), frames {a.counts['frames']}",
        f"image size  {a.image_size[0]}x{a.image_size[1]} (height x width)",
        f"obs/example {summary['observations']['min']}..{summary['observations']['max']}",
        "d1 (m)      "
        + (f"{summary['d1']['min']:.4f}..{summary['d1']['max']:.4f}" if summary["d1"] else "-"),
        f"{empty_text} {summary[empty_key]}",
        "example ids " + (f"{ids['first']} .. {ids['last']} (e.g. odms-data show {store} {ids['first']} "
                          "-o sheet.png)" if (ids := summary["example_ids"]) else "-"),
        f"digest      {a.digest}",
    ]
    if gen:
        lines.append(f"generator   version {a.generator_version}, preset {gen['preset']}, seed {gen['seed']}")
    if a.source:
        lines.append(f"source      {a.source}")
    if a.oddities:
        lines.append(f"oddities    {len(a.oddities)} recorded (see --json)")
    return summary, "\n".join(lines)


@click.command()
@click.argument("src", type=click.Path(), shell_complete=completion.stores)
@click.argument("dst", type=click.Path())
@click.option("--format", "fmt", type=click.Choice(["zarr", "hdf5"]), default=None,
              help="Backend of DST (default: from its suffix, .h5/.hdf5 = hdf5, else zarr).")
@click.option("--overwrite", is_flag=True, help="Replace DST if it exists.")
@click.option("--json", "as_json", is_flag=True, help="Print what was written as JSON.")
def convert(src, dst, fmt, overwrite, as_json):
    """Copy a store to the other backend, losslessly (the content digest is checked).

    \b
    Example:
      odms-data convert sim-val.zarr sim-val.h5
    """
    from ..store.convert import convert as convert_store

    with Bars("converting to {}") as bars:
        digest = convert_store(src, dst, fmt, overwrite=overwrite, progress=bars)
    if as_json:
        echo_json({"source": src, "output": dst, "digest": digest})
        return
    click.echo(f"wrote {dst}: digest {digest}")


@click.command()
@click.argument("store", type=click.Path(), shell_complete=completion.stores)
@click.argument("example_id")
@click.option("-o", "--output", type=click.Path(), required=True,
              help="Image file to write (PNG, or another format by its suffix).")
@click.option("--crop", is_flag=True, help="Cut every mask to the box around the object (with a margin), "
              "so that a small object fills its thumbnail.")
@click.option("--overwrite", is_flag=True, help="Replace an existing image file.")
def show(store, example_id, output, crop, overwrite):
    """Draw one example's masks as a contact sheet, with z and depth under each.

    \b
    Example:
      odms-data show sim-val.zarr sim-val/000042 -o sheet.png
      odms-data show sim-val.zarr sim-val/000042 --crop -o object.png
    """
    from ..publish.contact_sheet import contact_sheet, image_format, save_image

    check_replaceable(output, overwrite, option="output")
    image_format(output)
    with open_store(store) as s:
        sheet = contact_sheet(s.example(example_id), crop=crop)
    save_image(sheet, output, overwrite=overwrite)
    click.echo(f"wrote {output}")
