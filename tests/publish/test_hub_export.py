"""Export to the Hub's layout, read back with the real `datasets` and validated with `mlcroissant`."""

from __future__ import annotations

import json
import re
import subprocess
import sys

import datasets
import mlcroissant
import numpy as np
import pytest
import yaml
from click.testing import CliRunner

from odms_data.cli import main
from odms_data.cli.fixes import with_fix
from odms_data.errors import InputError
from odms_data.publish.hub_export import export_hub, sha256
from odms_data.publish.hub_metadata import columns_of, licence_of
from odms_data.simulate.generate_box_store import generate_box_store
from odms_data.simulate.generate_store import generate
from odms_data.simulate.params import GeneratorParams
from odms_data.store.format import StoreAttrs
from odms_data.store.reader import open_store

PARAMS = GeneratorParams(image_size=(60, 83), sizes=(20, 40), n_obs=4)  # odd width: padded mask rows


@pytest.fixture(autouse=True)
def offline(monkeypatch):
    monkeypatch.setenv("HF_HUB_OFFLINE", "1")
    monkeypatch.setenv("HF_DATASETS_OFFLINE", "1")


def _unpack(packed: list[bytes], height: int, width: int) -> np.ndarray:
    rows = np.frombuffer(b"".join(packed), np.uint8).reshape(len(packed), height, -1)
    return np.unpackbits(rows, axis=-1, count=width).astype(bool)


def _assert_round_trip(rows, store_path, every: int = 1, also: frozenset[int] = frozenset()) -> None:
    """Every row is its store example (each `every`-th and those in `also` compared in full),
    masks bit for bit."""
    with open_store(str(store_path)) as s:
        count = 0
        for i, row in enumerate(rows):
            count += 1
            if i % every and i not in also:
                continue
            ex = s.example(i)
            assert row["example_id"] == ex.example_id and row["n"] == ex.n == len(row["masks"])
            np.testing.assert_array_equal(_unpack(row["masks"], row["height"], row["width"]), ex.masks)
            np.testing.assert_array_equal(row["z"], ex.z)
            np.testing.assert_array_equal(np.array(row["depth"], float), ex.depth)  # NaN where unknown
            np.testing.assert_array_equal(row["d1"], ex.d1)
        assert count == s.n_examples


def test_generated_stores_round_trip_through_datasets_and_croissant(tmp_path):
    a, b = tmp_path / "a.zarr", tmp_path / "b.h5"
    generate(str(a), 23, PARAMS, seed=1, split="tiny-val")
    generate(str(b), 5, PARAMS, seed=2, split="tiny-test")
    out = tmp_path / "hub"
    exported = export_hub([str(a), str(b)], str(out), examples_per_file=10)
    assert [(e.split, e.examples, len(e.files)) for e in exported] == [("tiny-val", 23, 3),
                                                                        ("tiny-test", 5, 1)]

    ds = datasets.load_dataset(str(out), cache_dir=str(tmp_path / "cache"))
    assert sorted(ds) == ["tiny_test", "tiny_val"]
    _assert_round_trip(ds["tiny_val"], a)
    _assert_round_trip(ds["tiny_test"], b)

    card = (out / "README.md").read_text()
    header = yaml.safe_load(card.split("---")[1])
    assert header["license"] == "mit" and header["task_categories"] == ["depth-estimation"]
    assert header["size_categories"] == ["n<1K"] and "@inproceedings{GrCo20" in card

    meta = json.loads((out / "croissant.json").read_text())
    files = [d for d in meta["distribution"] if d["@type"] == "cr:FileObject"]
    assert sorted(f["contentUrl"] for f in files) == sorted(f for e in exported for f in e.files)
    assert all(f["sha256"] == sha256(out / f["contentUrl"]) for f in files)
    records = list(mlcroissant.Dataset(jsonld=str(out / "croissant.json")).records("examples"))
    assert len(records) == 28
    first = next(r for r in records if r["examples/example_id"] == b"tiny-val/000000")
    with open_store(str(a)) as s:
        np.testing.assert_array_equal(_unpack(first["examples/masks"], 60, 83), s.example(0).masks)


def _assert_box_round_trip(rows, store_path) -> None:
    """Every row is its store example of boxes: ids, sizes, label and each frame's box, movement
    and depth, float for float."""
    with open_store(str(store_path)) as s:
        count = 0
        for i, row in enumerate(rows):
            count += 1
            f = s.frames_of(i)
            assert (row["example_id"], row["source"], row["split"]) == (s.example_ids[i], s.sources[i],
                                                                        s.attrs.split)
            assert (row["n"], row["height"], row["width"]) == (len(f), s.height, s.width)
            np.testing.assert_array_equal(np.array(row["box"], float), s.box[f])
            np.testing.assert_array_equal(np.array(row["move"], float), s.move[f])
            np.testing.assert_array_equal(np.array(row["depth"], float), s.depth[f])  # NaN where unknown
            np.testing.assert_array_equal(row["d1"], s.d1[i])
        assert count == s.n_examples


def test_generated_box_stores_round_trip_through_datasets_and_croissant(tmp_path):
    a, b = tmp_path / "b.zarr", tmp_path / "c.h5"
    run = CliRunner()
    res = run.invoke(main, ["generate", "--boxes", "odmd", "-n", "50", "--name", "boxes-val", "-o", str(a)])
    assert res.exit_code == 0, res.output
    generate_box_store(str(b), 7, "odmd-perturb-detection", 2, split="boxes-test")
    out = tmp_path / "hub"
    res = run.invoke(main, ["export", str(a), str(b), "-o", str(out), "--examples-per-file", "20", "--json"])
    assert res.exit_code == 0, res.output
    assert [(e["split"], e["examples"], len(e["files"])) for e in json.loads(res.stdout)["splits"]] == [
        ("boxes-val", 50, 3), ("boxes-test", 7, 1)]

    ds = datasets.load_dataset(str(out), cache_dir=str(tmp_path / "cache"))
    assert sorted(ds) == ["boxes_test", "boxes_val"]
    assert ds["boxes_val"].column_names == list(columns_of("boxes"))  # no masks, no z
    _assert_box_round_trip(ds["boxes_val"], a)
    _assert_box_round_trip(ds["boxes_test"], b)

    card = (out / "README.md").read_text()
    header = yaml.safe_load(card.split("---")[1])
    assert header["license"] == "mit" and "bounding-boxes" in header["tags"]
    assert "@inproceedings{GrCoCVPR21" in card and "| `box` | list of Float |" in card
    assert "`masks`" not in card and "`z`" not in card

    meta = json.loads((out / "croissant.json").read_text())
    assert [f["name"] for f in meta["recordSet"][0]["field"]] == list(columns_of("boxes"))
    assert meta["url"] == "https://github.com/griffbr/ODMD"
    records = list(mlcroissant.Dataset(jsonld=str(out / "croissant.json")).records("examples"))
    assert len(records) == 57
    first = next(r for r in records if r["examples/example_id"] == b"boxes-val/0000000")
    with open_store(str(a)) as s:
        np.testing.assert_array_equal(np.array(first["examples/d1"]), s.d1[0])
        np.testing.assert_array_equal(np.stack(first["examples/box"]), s.box[s.frames_of(0)])


def test_export_holds_one_kind_and_refuses_a_mix_in_one_line(tmp_path):
    masks, boxes = tmp_path / "m.zarr", tmp_path / "b.zarr"
    generate(str(masks), 3, PARAMS, seed=1)
    generate_box_store(str(boxes), 3, "odmd", 1, split="boxes")
    r = subprocess.run([sys.executable, "-m", "odms_data.cli", "export", str(masks), str(boxes), "-o",
                        str(tmp_path / "hub")], capture_output=True, text=True)
    lines = r.stderr.strip().splitlines()
    assert r.returncode == 2 and len(lines) == 1, r.stderr
    assert f"{boxes}: a store of boxes cannot join an export of stores of masks" in lines[0]
    assert not (tmp_path / "hub").exists() and not (tmp_path / "hub.partial").exists()


def test_export_keeps_what_the_user_had(tmp_path):
    store = tmp_path / "s.zarr"
    generate(str(store), 3, PARAMS, seed=1)
    mine = tmp_path / "mine"
    mine.mkdir()
    (mine / "notes.txt").write_text("keep me")

    def run(*args):
        return subprocess.run([sys.executable, "-m", "odms_data.cli", "export", str(store), *args],
                              capture_output=True, text=True)

    for args in (["-o", str(mine)], ["-o", str(mine), "--overwrite"]):
        r = run(*args)
        lines = r.stderr.strip().splitlines()
        assert r.returncode == 2 and len(lines) == 1 and lines[0].startswith("odms-data: error:"), r.stderr
    assert (mine / "notes.txt").read_text() == "keep me" and not (tmp_path / "mine.partial").exists()
    r = run("-o", str(tmp_path / "hub"), "--json")
    assert r.returncode == 0, r.stderr
    assert json.loads(r.stdout)["splits"][0]["examples"] == 3
    assert run("-o", str(tmp_path / "hub"), "--overwrite").returncode == 0  # an earlier export may go


def test_licence_known_for_generated_and_official_data_only():
    def attrs(split, domain):
        return StoreAttrs(split=split, domain=domain, image_size=(4, 4), counts={})

    assert licence_of([attrs("sim-val", "generated")]) == "mit"
    assert licence_of([attrs("robot-val", "robot"), attrs("sim-val", "generated")]) == "other"
    with pytest.raises(InputError, match="licence of split cup is not known") as refused:
        licence_of([attrs("cup", "recording")])
    assert "give --license" in with_fix(refused.value)


def test_official_driving_split_round_trips(official_stores, tmp_path):
    """The release's driving examples: 760x1280 masks, NaN depths at empty masks, research-only
    licence. Streamed, as datasets' cache would hold the masks unpacked (about 700 MB)."""
    out = tmp_path / "hub"
    export_hub([str(official_stores["driving-val"])], str(out))
    header = yaml.safe_load((out / "README.md").read_text().split("---")[1])
    assert header["license"] == "other" and header["license_name"] == "odms-research-only"
    ds = datasets.load_dataset(str(out), split="driving_val", streaming=True)
    with open_store(str(official_stores["driving-val"])) as s:
        unknown = frozenset(i for i in range(s.n_examples) if np.isnan(s.depth[s.frames_of(i)]).any())
    assert unknown  # the release's NaN depths at empty masks
    _assert_round_trip(ds, official_stores["driving-val"], every=5, also=unknown)


def test_odmds_robot_set_round_trips_with_its_unknown_depths(odmd_data, tmp_path):
    """ODMD's robot val set, imported: NaN depths at its inner frames; ODMD states no licence for
    its data, so the user gives one."""
    res = CliRunner().invoke(main, ["import", "odmd", str(odmd_data), "-o", str(tmp_path / "s"),
                                    "--set", "odmd-robot-val"])
    assert res.exit_code == 0, res.output
    store, out = tmp_path / "s" / "odmd-robot-val.zarr", tmp_path / "hub"
    with pytest.raises(InputError, match="licence of split odmd-robot-val is not known"):
        export_hub([str(store)], str(out))
    assert [e.files for e in export_hub([str(store)], str(out), licence="unknown")] == [
        [f"data/odmd-robot-val/odmd-robot-val-{k:05d}-of-00003.parquet" for k in range(3)]]
    header = yaml.safe_load((out / "README.md").read_text().split("---")[1])
    assert header["license"] == "unknown" and header["pretty_name"] == "hub"
    with open_store(str(store)) as s:
        assert np.isnan(s.depth).any()  # the robot sets' inner frames
    _assert_box_round_trip(datasets.load_dataset(str(out), split="odmd_robot_val",
                                                 cache_dir=str(tmp_path / "cache")), store)


def test_the_card_shows_a_hostile_title_and_licence_as_text(tmp_path):
    """`export --name` and `--license` reach the card only escaped; a licence is an SPDX
    identifier or one line, and anything else is refused before the export starts."""
    store = tmp_path / "s.zarr"
    generate(str(store), 3, PARAMS, seed=1)
    hostile = '<img src=x onerror=alert(1)> [home](javascript:alert(1)) "\n---\nlicense: x'
    run = CliRunner().invoke
    for licence in ("mit\n---\n<script>alert(1)</script>", "x" * 201, " mit", "a\x1b[31m"):
        r = run(main, ["export", str(store), "-o", str(tmp_path / "no"), "--license", licence])
        assert r.exit_code == 2 and len(r.stderr.splitlines()) == 1, r.output
        assert "a licence is an SPDX identifier" in r.stderr and not (tmp_path / "no").exists()
    r = run(main, ["export", str(store), "-o", str(tmp_path / "hub"), "--name", hostile,
                   "--license", "Research only <b>please</b>"])
    assert r.exit_code == 0, r.output
    card = (tmp_path / "hub" / "README.md").read_text()
    header = yaml.safe_load(card.split("---\n")[1])
    assert header["pretty_name"] == hostile  # the whole title, quoted, in the header it cannot end
    assert (header["license"], header["license_name"]) == ("other", "research-only-b-please-b")
    body = card.split("---\n", 2)[2]  # the Markdown the Hub renders
    assert "<img" not in card and "<b>" not in card and not re.search(r"(?<!\\)\]\(javascript:", body)
    assert ("# &lt;img src=x onerror=alert(1)&gt; \\[home\\]\\(javascript:alert(1)) \" --- license: x\n"
            in card)
    assert "licence: Research only &lt;b&gt;please&lt;/b&gt;." in card
