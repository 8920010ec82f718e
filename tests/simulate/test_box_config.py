"""`generate --boxes --config FILE`: ODMD's generator configuration files (griffbr/ODMD,
config/data_gen and config/camera) read with the meaning the authors' generator gives them
(simulate/box_config.py). The files below are written here with the keys and values of the
authors' files that each names; the project does not ship theirs."""

from __future__ import annotations

import json
import os
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from odms_data.cli import main
from odms_data.errors import InputError
from odms_data.simulate.box_config import read_box_config
from odms_data.simulate.box_examples import BOX_PRESETS, sample_box_examples
from odms_data.store.box_rule import example_boxes
from odms_data.store.reader import open_store

# config/data_gen/standard_data.yaml
STANDARD_DATA = """data_description: XYZ motion based on robot-collected data
z_lim: [0.55,1]
move_max: [0.25,0.175,0.325]
size_lim: [0.01,0.175]
move_min: [0,0,0.05]
num_pos: 10
perturb: True
std_dev: 0.001
cam_dev: 0.01
shuffle: 0.1
end_swap: True
"""
# config/data_gen/ODMS.yaml
ODMS_DATA = STANDARD_DATA.replace("XYZ motion based on robot-collected data", "Z motion for ODMS").replace(
    "move_max: [0.25,0.175,0.325]", "move_max: [0,0,0.4625]")
# config/camera/hsr_grasp_camera.yaml
HSR_CAMERA = """camera_name: HSR Grasp Camera
image_dim: [480,640]
fx: 205.5
fy: 205.5
cx: 320.5
cy: 240.5"""
# config/camera/ODMS_camera.yaml
ODMS_CAMERA = HSR_CAMERA.replace("HSR Grasp Camera", "Pinhole ODMS Camera").replace("205.5", "240.5")

# preset -> the authors' files it is: the released generator's demo pairs standard_data with the
# HSR camera; ODMS.yaml's motion goes with the ODMS camera
AUTHORS = {"odmd": (STANDARD_DATA, HSR_CAMERA), "odms": (ODMS_DATA, ODMS_CAMERA)}


def _files(tmp_path: Path, *texts: str) -> list[str]:
    paths = []
    for i, text in enumerate(texts):
        path = tmp_path / f"config{i}.yaml"
        path.write_text(text)
        paths.append(str(path))
    return paths


def _generate(args: list[str]) -> tuple[int, str]:
    res = CliRunner().invoke(main, ["generate", "-n", "30", "--seed", "4", "--json", *args])
    return res.exit_code, res.output


def _tree(path: Path) -> dict[str, bytes]:
    return {str(f.relative_to(path)): f.read_bytes() for f in sorted(path.rglob("*")) if f.is_file()}


@pytest.mark.parametrize("preset", sorted(AUTHORS))
def test_the_authors_config_gives_its_presets_store_byte_for_byte(tmp_path, preset):
    files = _files(tmp_path, *AUTHORS[preset])
    assert read_box_config(files) == BOX_PRESETS[preset]
    code, out = _generate(["--boxes", "--config", files[0], "--config", files[1],
                           "-o", str(tmp_path / "c.zarr")])
    assert code == 0, out
    code, out = _generate(["--boxes", preset, "-o", str(tmp_path / "p.zarr")])
    assert code == 0, out
    assert json.loads(out[out.index("{"):])["boxes"] == preset
    made, named = _tree(tmp_path / "c.zarr"), _tree(tmp_path / "p.zarr")
    assert made == named and any(name.endswith("zarr.json") for name in made)


@pytest.mark.parametrize(("preset", "change"), [
    ("odmd-normal", {"perturb: True": "perturb: False"}),
    ("odmd-perturb-motion", {"std_dev: 0.001": "std_dev: 0", "shuffle: 0.1": "shuffle: 0"}),
    ("odmd-perturb-detection", {"cam_dev: 0.01": "cam_dev: 0.0"}),
])
def test_the_perturbation_keys_give_the_other_presets(tmp_path, preset, change):
    text = STANDARD_DATA
    for old, new in change.items():
        text = text.replace(old, new)
    assert read_box_config(_files(tmp_path, text, HSR_CAMERA)) == BOX_PRESETS[preset]


def test_a_later_file_replaces_an_earlier_files_keys_as_the_authors_camera_file_does(tmp_path):
    """ODMS.yaml's motion seen by the HSR camera: no preset, the files' keys, in order."""
    params = read_box_config(_files(tmp_path, ODMS_DATA, ODMS_CAMERA, HSR_CAMERA, "num_pos: 4"))
    assert params == replace(BOX_PRESETS["odms"], fx=205.5, fy=205.5, num_pos=4)
    assert read_box_config(_files(tmp_path, "shuffle: 0.5\ncam_dev: 0.02"), "odmd") == replace(
        BOX_PRESETS["odmd"], shuffle=0.5, cam_dev=0.02)


def test_rotation_is_a_setting_and_its_store_records_it(tmp_path):
    rotation, = _files(tmp_path, "rotation: 3  # degrees, odms-data's setting\n")
    out = tmp_path / "turned.zarr"
    code, text = _generate(["--boxes", "odmd-normal", "--config", rotation, "-o", str(out)])
    assert code == 0, text
    assert json.loads(text[text.index("{"):])["boxes"] is None  # no preset turns
    want = sample_box_examples(replace(BOX_PRESETS["odmd-normal"], rotation=3.0), 4, range(30))
    straight = sample_box_examples(BOX_PRESETS["odmd-normal"], 4, range(30))
    with open_store(str(out)) as s:
        assert s.attrs.generator["preset"] is None and s.attrs.generator["params"]["rotation"] == 3.0
        got = example_boxes(s, range(30))
    np.testing.assert_array_equal(got.boxes, want["boxes"])
    np.testing.assert_array_equal(got.move, straight["move"])  # the true translations
    assert not np.allclose(got.boxes, straight["boxes"])


def _refusal(tmp_path: Path, args: list[str]) -> str:
    code, out = _generate([*args, "-o", str(tmp_path / "never.zarr")])
    assert code == 2, out
    assert out.count("\n") == 1 and "Traceback" not in out
    assert not (tmp_path / "never.zarr").exists()
    return out


@pytest.mark.parametrize(("text", "words"), [
    ("num_obs: 10", ["'num_obs'", "did you mean num_pos?"]),
    ("model_name: DBox", ["'model_name'", "unknown key"]),  # config/model's DBox.yaml
    ("size_range: [0.01, 0.175]", ["size_range", "derives it from size_lim"]),  # data_gen.py's docstring name
    ("xminb: 0.3", ["xminb", "field of view's margins"]),
    ("z_lim: [1]", ["z_lim must be a list of 2 numbers"]),
    ("std_dev: 1e-3", ["std_dev must be a number", "'1e-3'"]),  # YAML 1.1, as the authors read it: text
    ("num_pos: 10.0", ["num_pos must be a whole number"]),
    ("perturb: 1", ["perturb must be true or false"]),
    ("shuffle: 1.5", ["shuffle must be from 0 to 1"]),
    ("move_min: [0, 0, 0.5]", ["move_min must be from 0 to move_max"]),
    ("z_lim: [0.05, 1]", ["raise z_lim"]),
    ("rotation: 28", ["rotation must be from 0 to 27.1 degrees"]),
    ("image_dim: [480, 100000]", ["image_dim"]),
    ("fx: .nan", ["fx must be a number"]),
])
def test_a_key_or_value_the_generator_cannot_honour_is_one_line_naming_file_and_key(tmp_path, text, words):
    config, = _files(tmp_path, text)
    out = _refusal(tmp_path, ["--boxes", "odmd", "--config", config])
    assert config in out
    for word in words:
        assert word in out


def test_without_a_preset_the_files_give_every_key(tmp_path):
    data, = _files(tmp_path, STANDARD_DATA)
    out = _refusal(tmp_path, ["--boxes", "--config", data])
    assert "no image_dim, fx, fy, cx, cy" in out


@pytest.mark.parametrize(("content", "words"), [
    (b"a: " + b"[" * 30_000 + b"]" * 30_000, ["nested deeper than"]),  # composing it would recurse
    (b"a:\n" + b"".join(b" " * i + b"- \n" for i in range(1, 300)), ["nested deeper than"]),
    (b"z_lim: [0.55, 1]\n" * 5000, ["larger than 65536 bytes"]),
    (b"a: &x [1, 2]\nz_lim: *x", ["anchors and aliases"]),
    (b"z_lim: !!python/tuple [0.55, 1]", ["tags are not read"]),
    (b"- 1\n- 2", ["expected a mapping"]),
    (b"z_lim: [0.55, 1\nfx: 2", ["not valid YAML"]),
    (b"fx: \xff\xfe", ["not valid YAML"]),
    (b"3: 0.1", ["key 3 is not a setting's name"]),
])
def test_hostile_files_are_one_line(tmp_path, content, words):
    path = tmp_path / "hostile.yaml"
    path.write_bytes(content)
    out = _refusal(tmp_path, ["--boxes", "odmd", "--config", str(path)])
    assert str(path) in out
    for word in words:
        assert word in out


def test_config_needs_boxes_and_boxes_needs_a_preset_or_a_config(tmp_path):
    config, = _files(tmp_path, "rotation: 1")
    assert "give --boxes --config FILE" in _refusal(tmp_path, ["--config", config])
    assert "--boxes takes a preset" in _refusal(tmp_path, ["--boxes"])
    with pytest.raises(InputError, match="unknown box preset"):
        read_box_config([config], "odmx")


def test_what_is_not_a_regular_file_is_refused_without_waiting(tmp_path):
    fifo = tmp_path / "fifo.yaml"
    os.mkfifo(fifo)
    assert "is a FIFO, not a generator config" in _refusal(tmp_path, ["--boxes", "odmd", "--config",
                                                                      str(fifo)])
    assert "is a folder" in _refusal(tmp_path, ["--boxes", "odmd", "--config", str(tmp_path)])
    missing = str(tmp_path / "none.yaml")
    assert "no such generator config" in _refusal(tmp_path, ["--boxes", "odmd", "--config", missing])


def test_a_long_value_or_key_is_shown_cut(tmp_path):
    for text, start in (("std_dev: " + "9" * 60_000 + "x", "std_dev must be a number, got '999"),
                        ("? " + "k" * 60_000 + "\n: 1", "unknown key 'kkk")):  # a long key is explicit
        config, = _files(tmp_path, text)
        out = _refusal(tmp_path, ["--boxes", "odmd", "--config", config])
        assert start in out and "..." in out and len(out) < 500
