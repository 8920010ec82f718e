"""`odms-data generate`."""

from __future__ import annotations

import json

import click

from .. import safe_json
from ..errors import InputError
from ..extras import optional
from ..simulate.box_examples import BOX_PRESETS, DEFAULT_BOX_EXAMPLES_PER_SHARD
from ..simulate.kernel import will_compile
from ..simulate.params import (
    DEFAULT_EXAMPLES_PER_SHARD,
    PRESETS,
    closest_parameter,
    merged_params,
)
from . import completion, echo_json
from .progress import progress


class _PresetOrNone(click.Choice):
    """A box preset's name, or nothing (`--boxes` given alone, as with --config)."""

    def convert(self, value, param, ctx):
        return value if value == "" else super().convert(value, param, ctx)


COMPILING = "compiling the drawing kernels for this machine, once (about 10 s; later runs load them)"


def _parse_param(values: tuple[str, ...]) -> dict:
    out = {}
    for item in values:
        key, sep, raw = item.partition("=")
        if not sep or not key:
            name = closest_parameter(key) or "d_max"
            raise InputError(f"--param '{item}': expected NAME=VALUE, e.g. --param "
                             f"{name}={json.dumps(getattr(PRESETS['standard'], name))}")
        try:
            out[key] = safe_json.loads(raw, f"--param '{item}'")
        except InputError as e:
            raise InputError(f"{e}; the value is not a number or JSON list") from None
    return out


def _split_recipe(split_name: str, given: list[str]):
    """The named split's recipe; InputError when options that it fixes were `given` too."""
    from ..simulate.generate_store import split_recipe

    recipe = split_recipe(split_name)
    if given:
        raise InputError(f"--split {split_name} fixes its parameters; drop {', '.join(given)}")
    return recipe


@click.command()
@click.option("--split", "split_name", shell_complete=completion.splits,
              help="Generate a named split of splits/ and verify its digest.")
@click.option("-n", "--count", type=click.IntRange(min=1), help="Number of examples.")
@click.option("--preset", type=click.Choice(sorted(PRESETS)), default=None,
              help="Parameter preset (default: standard).")
@click.option("--seed", type=click.IntRange(min=0), default=None, help="Random seed (default 0).")
@click.option("--n-obs", type=click.IntRange(min=2), default=None,
              help="Observations per example (default 10).")
@click.option("--param", "params", multiple=True, metavar="NAME=VALUE",
              help="Override any generator parameter, e.g. --param d_max=0.9 (repeatable).")
@click.option("--name", "store_split", default=None,
              help="Split name recorded in the store and its example ids (default: generated).")
@click.option("-o", "--output", type=click.Path(), default=None,
              help="Output store (default: <split>.zarr, or .h5 with --format hdf5).")
@click.option("--format", "fmt", type=click.Choice(["zarr", "hdf5"]), default=None,
              help="Store backend (default: from the output suffix, else zarr).")
@click.option("--workers", type=click.IntRange(min=1), default=None,
              help="Worker processes (default: as many as the work is worth, up to all cores; "
                   "a run of fewer than ~3,000 480x640 examples uses one, in-process).")
@click.option("--examples-per-shard", type=click.IntRange(min=1), default=None,
              help=f"Examples per shard (one task each); does not change the content (default: "
                   f"{DEFAULT_EXAMPLES_PER_SHARD}, with --boxes {DEFAULT_BOX_EXAMPLES_PER_SHARD}).")
@click.option("--boxes", "box_preset", type=_PresetOrNone(list(BOX_PRESETS)), is_flag=False, flag_value="",
              default=None, help="Write a store of boxes (ODMD's kind) from the box generator with this "
                   "preset, or with the settings of --config, rather than masks; takes -n, --seed, --name, "
                   "-o, --format, --workers, --examples-per-shard and --scheduler.")
@click.option("--config", "configs", multiple=True, type=click.Path(), metavar="FILE",
              help="With --boxes: an ODMD generator config (config/data_gen/*.yaml, config/camera/*.yaml; "
                   "and rotation: degrees, odms-data's), applied in order over the --boxes preset, if any "
                   "(repeatable; without a preset the files give every key).")
@click.option("--overwrite", is_flag=True, help="Replace an existing store.")
@click.option("--json", "as_json", is_flag=True, help="Print what was written as JSON.")
@click.option("--scheduler", metavar="ADDRESS", default=None,
              help="Run the shards on the Dask cluster of this scheduler (e.g. tcp://host:8786) "
                   "instead of local --workers; needs the dask extra. The output must be a path "
                   "every worker sees, or a URL such as s3://bucket/train.zarr.")
def generate(split_name, count, preset, seed, n_obs, params, store_split, output, fmt, workers,
             examples_per_shard, box_preset, configs, overwrite, as_json, scheduler):
    """Generate simulated ODMS examples into a store.

    \b
    Examples:
      odms-data generate --split sim-val
      odms-data generate -n 100000 --preset perturb --seed 7 -o train.zarr --workers 8
      odms-data generate -n 2560000 --scheduler tcp://head:8786 -o s3://lab/odms/train.zarr
      odms-data generate -n 10000 --boxes odmd --seed 3 -o odmd-train.zarr
      odms-data generate -n 10000 --boxes --config standard_data.yaml --config hsr_grasp_camera.yaml
    """
    if scheduler and workers is not None:
        raise InputError("--workers and --scheduler exclude each other; the cluster has its own workers")
    if scheduler:
        optional("distributed", "odms-data generate --scheduler")  # before the store is begun
    if configs and box_preset is None:
        raise InputError("--config reads the box generator's settings (ODMD's config files): give --boxes "
                         "--config FILE")
    if box_preset is not None:
        if not box_preset and not configs:
            raise InputError(f"--boxes takes a preset ({', '.join(BOX_PRESETS)}) or --config FILE")
        given = {"--split": split_name, "--preset": preset, "--n-obs": n_obs, "--param": params}
        _generate_boxes(box_preset or None, configs, count, seed, store_split, output, fmt, overwrite,
                        as_json, [o for o, v in given.items() if v], workers, examples_per_shard, scheduler)
        return
    _generate_masks(split_name, count, preset, seed, n_obs, params, store_split, output, fmt, workers,
                    examples_per_shard or DEFAULT_EXAMPLES_PER_SHARD, overwrite, as_json, scheduler)


def _generate_masks(split_name, count, preset, seed, n_obs, params, store_split, output, fmt, workers,
                    examples_per_shard, overwrite, as_json, scheduler):
    """`generate` of a store of masks."""
    from ..simulate.generate_store import generate as generate_store
    from ..store.format import store_path
    from ..store.manifests import check_against_manifest

    overrides = _parse_param(params)
    manifest = None
    if split_name is not None:
        given = [o for o, v in (("-n", count), ("--preset", preset), ("--seed", seed),
                                ("--n-obs", n_obs), ("--param", params), ("--name", store_split)) if v]
        recipe = _split_recipe(split_name, given)
        manifest, count, preset, seed = recipe.manifest, recipe.count, recipe.preset, recipe.seed
        overrides, store_split = recipe.overrides, split_name
    elif count is None:
        raise InputError("give --split NAME or -n COUNT")
    if n_obs is not None:
        overrides["n_obs"] = n_obs
    preset = preset or "standard"
    gen_params = merged_params(preset, overrides)
    store_split = store_split or "generated"
    if output is None:
        output = str(store_path(".", store_split, "hdf5" if fmt == "hdf5" else "zarr"))
    with progress(count, f"generating {output}", notice=COMPILING if will_compile() else None) as update:
        attrs = generate_store(
            output, count, gen_params, seed or 0, split=store_split, preset=preset, fmt=fmt,
            workers=workers, examples_per_shard=examples_per_shard, overwrite=overwrite,
            progress=update, scheduler=scheduler,
        )
    if manifest is not None:
        check_against_manifest(attrs, manifest, output)
    if as_json:
        echo_json({"output": output, "split": store_split, "examples": count, "preset": preset,
                               "seed": seed or 0, "digest": attrs.digest,
                               "manifest": f"splits/{split_name}.json" if manifest else None})
        return
    click.echo(f"wrote {output}: {count} examples, digest {attrs.digest}")
    if manifest is not None:
        click.echo(f"digest matches splits/{split_name}.json")


def _generate_boxes(preset, configs, count, seed, split, output, fmt, overwrite, as_json, given, workers,
                    examples_per_shard, scheduler):
    """`generate --boxes [PRESET] [--config FILE ...]`: a store of boxes from the box generator."""
    from ..simulate.box_config import read_box_config
    from ..simulate.box_examples import preset_name
    from ..simulate.generate_box_store import generate_box_store
    from ..store.format import store_path

    if given:
        raise InputError(f"--boxes takes --config, -n, --seed, --name, -o, --format, --workers, "
                         f"--examples-per-shard and --scheduler, not {given[0]}")
    if count is None:
        raise InputError("give -n COUNT with --boxes")
    box_params = read_box_config(list(configs), preset) if configs else BOX_PRESETS[preset]
    split = split or "generated"
    output = output or str(store_path(".", split, "hdf5" if fmt == "hdf5" else "zarr"))
    with progress(count, f"generating {output}") as update:
        attrs = generate_box_store(output, count, box_params, seed or 0, split=split, fmt=fmt,
                                   overwrite=overwrite, progress=update, workers=workers,
                                   examples_per_shard=examples_per_shard or DEFAULT_BOX_EXAMPLES_PER_SHARD,
                                   scheduler=scheduler)
    if as_json:
        echo_json({"output": output, "split": split, "examples": count, "boxes": preset_name(box_params),
                   "config": list(configs), "seed": seed or 0, "digest": attrs.digest})
        return
    click.echo(f"wrote {output}: {count} examples of boxes, digest {attrs.digest}")
