"""`generate --boxes`: stores of boxes whose example k is the box generator's (preset, seed, k),
the same the box stream gives, whatever the store's size."""

from __future__ import annotations

import json

import numpy as np
from click.testing import CliRunner

from odms_data.cli import main
from odms_data.loaders.sources import GeneratedExamples
from odms_data.simulate.box_examples import BOX_PRESETS
from odms_data.store.box_rule import example_boxes
from odms_data.store.reader import open_store


def _generate(tmp_path, name, count, preset="odmd", seed=5):
    out = str(tmp_path / f"{name}.zarr")
    res = CliRunner().invoke(main, ["generate", "-n", str(count), "--boxes", preset, "--seed", str(seed),
                                    "--name", name, "-o", out, "--json"])
    assert res.exit_code == 0, res.output
    return out, json.loads(res.stdout[res.stdout.index("{"):])["digest"]


def test_example_k_is_the_generators_k_in_any_store_and_through_the_stream(tmp_path):
    small, _ = _generate(tmp_path, "a", 7)
    big, _ = _generate(tmp_path, "b", 20)
    stream = GeneratedExamples(BOX_PRESETS["odmd"], seed=5)
    with open_store(small) as s, open_store(big) as b:
        assert s.kind == b.kind == "boxes" and s.attrs.generator["preset"] == "odmd"
        assert s.attrs.generator_version == 2  # the counter-based streams
        ex_s, ex_b = example_boxes(s, range(7)), example_boxes(b, range(7))
        np.testing.assert_array_equal(ex_s.boxes, ex_b.boxes)
        np.testing.assert_array_equal(ex_s.move, ex_b.move)
        got = stream.transform.batch(ex_b.boxes, ex_b.move, ex_b.depth)
    want = stream.batch(range(7))
    for key in ("inputs", "depth_norm", "depth"):
        np.testing.assert_array_equal(got[key], want[key])


def test_the_same_seed_gives_the_same_digest_and_another_seed_another(tmp_path):
    _, one = _generate(tmp_path, "x", 30)
    (tmp_path / "again").mkdir()
    _, two = _generate(tmp_path / "again", "x", 30)
    _, other = _generate(tmp_path, "y", 30, seed=6)
    assert one == two != other


def test_normal_boxes_give_box_ls_its_exact_depths(tmp_path):
    store, _ = _generate(tmp_path, "n", 50, preset="odmd-normal")
    res = CliRunner().invoke(main, ["baseline", "box-ls", store, "-o", str(tmp_path / "p.csv")])
    assert res.exit_code == 0, res.output
    res = CliRunner().invoke(main, ["score", str(tmp_path / "p.csv"), "--data", store, "--json"])
    assert json.loads(res.stdout)["splits"][0]["mean_percent_error"] < 1e-6


def test_workers_and_examples_per_shard_leave_the_digest_as_one_worker_made_it(tmp_path):
    digests = set()
    for name, more in (("one", ["--workers", "1"]), ("two", ["--workers", "2", "--examples-per-shard", "7"]),
                       ("hdf", ["--workers", "2", "--examples-per-shard", "16", "--format", "hdf5"])):
        out = str(tmp_path / f"{name}.{'h5' if name == 'hdf' else 'zarr'}")
        res = CliRunner().invoke(main, ["generate", "-n", "40", "--boxes", "odmd", "--seed", "3", "-o", out,
                                        "--json", *more])
        assert res.exit_code == 0, res.output
        digests.add(json.loads(res.stdout[res.stdout.index("{"):])["digest"])
        with open_store(out) as s:
            assert s.n_examples == 40 and s.example_ids[-1] == "generated/0000039"
    assert len(digests) == 1


def test_a_store_its_readers_refuse_never_replaces_the_old_one(tmp_path):
    """`--name 'my split'` breaks the format's split-name rule: one line, exit 2, old store intact."""
    out, digest = _generate(tmp_path, "good", 5)
    res = CliRunner().invoke(main, ["generate", "-n", "5", "--boxes", "odmd", "--name", "my split", "-o", out,
                                    "--overwrite"])
    assert res.exit_code == 2, res.output
    assert res.output.count("\n") == 1 and "my split" in res.output and "nothing was replaced" in res.output
    with open_store(out) as s:
        assert s.attrs.split == "good" and s.attrs.digest == digest
    assert sorted(p.name for p in tmp_path.iterdir()) == ["good.zarr"]
