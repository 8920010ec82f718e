"""A mistyped example, generator parameter or leaderboard folder gets a one-line error that names
what was most likely meant (exit 2), not a wrong guess or an empty result."""

from __future__ import annotations

import json

import pytest
from click.testing import CliRunner

from odms_data.cli import main
from odms_data.simulate.generate_store import generate
from odms_data.simulate.params import GeneratorParams


def fails(args: list[str], *fragments: str) -> str:
    r = CliRunner().invoke(main, args)
    lines = r.stderr.strip().splitlines()
    assert r.exit_code == 2 and len(lines) == 1 and lines[0].startswith("odms-data: error: "), r.output
    for f in fragments:
        assert f in lines[0], lines[0]
    return lines[0]


@pytest.fixture(scope="module")
def store(tmp_path_factory) -> str:
    path = tmp_path_factory.mktemp("dym") / "sim-val.zarr"
    params = GeneratorParams(image_size=(48, 64), sizes=(20,))
    generate(str(path), 50, params, seed=5, split="sim-val", workers=1)
    return str(path)


@pytest.mark.parametrize("given", ["42", "042", "sim-val/042", "sim-val/42", "sim-val/0000042"])
def test_show_an_example_by_its_number(tmp_path, store, given):
    line = fails(["show", store, given, "-o", str(tmp_path / "s.png")], f"no example '{given}'")
    assert line.endswith("; did you mean sim-val/000042?"), line
    assert not (tmp_path / "s.png").exists()


def test_show_an_example_by_a_number_past_the_store(tmp_path, store):
    line = fails(["show", store, "sim-val/000077", "-o", str(tmp_path / "s.png")], "no example")
    assert "000077" not in line.split("did you mean")[-1]  # no id of that number: only alike ones


@pytest.mark.parametrize("given", ["dmax", "dmax=0.5"])
def test_generate_param_suggests_the_parameter(tmp_path, given):
    fails(["generate", "-n", "2", "--param", given, "-o", str(tmp_path / "x.zarr")], "d_max")
    assert not list(tmp_path.iterdir())


def test_generate_param_names_the_value_form_of_the_suggestion(tmp_path):
    fails(["generate", "-n", "2", "--param", "imagesize", "-o", str(tmp_path / "x.zarr")],
          "--param image_size=[480, 640]")


def test_leaderboard_folder_that_is_not_there(tmp_path):
    (tmp_path / "leaderboard").mkdir()
    (tmp_path / "leaderboard" / "a.json").write_text(json.dumps({"name": "a"}))
    fails(["leaderboard", "--dir", str(tmp_path / "leaderbord")], "leaderbord: no such folder",
          f"did you mean {tmp_path / 'leaderboard'}?")


def test_leaderboard_folder_without_entries(tmp_path):
    fails(["leaderboard", "--dir", str(tmp_path)], "holds no leaderboard entries")
