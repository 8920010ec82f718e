"""The commit rule (outputs.py `check`): an export and a training run's files pass their readers'
checks before they replace anything, as a store passes the readers' checks before its rename; what
a reader refuses is one line (a WriteError, exit code 2) and the old output stays as it was."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest
import torch
from click.testing import CliRunner

from odms_data.cli import main
from odms_data.errors import WriteError
from odms_data.network.checkpoint import Checkpoint
from odms_data.network.run_folder import BEST, CONFIG, LAST, RunFolder, TrainConfig
from odms_data.network.training import _save, train
from odms_data.outputs import atomic_folder
from odms_data.publish.hub_export import EXPORT, check_export, export_hub
from odms_data.simulate.generate_store import generate
from odms_data.simulate.params import GeneratorParams


def _files(folder: Path) -> dict[str, bytes]:
    return {str(p.relative_to(folder)): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}


@pytest.fixture(scope="module")
def store(tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("commit") / "tiny-val.zarr"
    generate(str(path), 4, GeneratorParams(image_size=(24, 36), sizes=(12, 20)), 3, split="tiny-val",
             workers=1)
    return path


def _damage_parquet(folder: Path, name: str) -> None:
    (folder / name).write_bytes((folder / name).read_bytes()[:64])


def _unquote_the_title(folder: Path, name: str) -> None:
    card = folder / "README.md"
    card.write_text(card.read_text().replace('pretty_name: "hub"', "pretty_name: [hub"))


@pytest.mark.parametrize("damage", [_damage_parquet, _unquote_the_title])
def test_an_export_its_readers_refuse_replaces_nothing(tmp_path, store, damage):
    out = tmp_path / "hub"
    exported = export_hub([str(store)], str(out))
    before = _files(out)
    with pytest.raises(WriteError, match=r"hub: what was written does not read back .*nothing was replaced"):
        with atomic_folder(out, EXPORT, overwrite=True, check=lambda f: check_export(f, exported)) as partial:
            shutil.copytree(out, partial, dirs_exist_ok=True)
            damage(partial, exported[0].files[0])
    assert _files(out) == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["hub"]


def test_a_finished_export_passes_its_readers_checks(tmp_path, store):
    r = CliRunner().invoke(main, ["export", str(store), "-o", str(tmp_path / "hub"), "--name", "a\n|---|"])
    assert r.exit_code == 0, r.output
    check_export(tmp_path / "hub", export_hub([str(store)], str(tmp_path / "again")))


def test_a_checkpoint_its_reader_refuses_replaces_nothing(tmp_path, store):
    """A tensor layout the checkpoint reader refuses (sparse) is never committed over best.pt."""
    run = tmp_path / "run"
    config = TrainConfig.recipe("odn-l", n_obs=3, iterations=1, batch_size=2, val=(str(store),))
    train(run, config, workers=0, device="cpu")
    before = _files(run)
    sparse = Checkpoint(2, {"w": torch.zeros(2, 2).to_sparse()})
    with pytest.raises(WriteError, match=r"best.pt: what was written does not read back \(.*sparse"):
        _save(run / BEST, sparse)
    assert _files(run) == before
    assert sorted(p.name for p in run.iterdir()) == sorted([CONFIG, LAST, BEST, "best-tiny-val.pt",
                                                            "curves.csv"])
    assert RunFolder(run).config() == config
