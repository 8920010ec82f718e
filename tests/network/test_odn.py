"""ODN's architecture: the authors' parameter counts, the shapes through it, its inputs."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from odms_data.errors import InputError
from odms_data.network.odn import build, inputs, transform
from odms_data.network.variants import VARIANTS, variant


def _count(model: torch.nn.Module) -> int:
    return sum(p.numel() for p in model.parameters() if p.requires_grad)


@pytest.mark.parametrize(("name", "radial", "count"), [
    ("odn-l", True, 1_656_137), ("odn-l", False, 1_649_865), ("odn-dbar", False, 1_649_865),
    ("odn-d", False, 1_650_122),
])
def test_parameter_counts_are_the_authors(name, radial, count):
    assert _count(build(variant(name), 10, radial)) == count


def test_layers_and_shapes():
    model = build(variant("odn-l"), 10, radial=True).eval()
    stem = model.stem[0]
    assert (stem.in_channels, stem.out_channels, stem.kernel_size, stem.stride, stem.padding, stem.bias) == (
        11, 32, (14, 14), (2, 2), (3, 3), None)
    shapes = []
    for block in model.blocks:
        block.register_forward_hook(lambda m, i, o: shapes.append(tuple(o.shape[1:])))
    out = model(torch.rand(3, 11, 112, 112), torch.rand(3, 8))
    assert shapes == [(64, 27, 27), (128, 14, 14), (128, 7, 7), (256, 4, 4)]
    assert out.shape == (3,)
    assert (model.hidden.in_features, model.out.in_features) == (264, 264)  # distances join both layers


def test_the_distances_change_the_output():
    model = build(variant("odn-d"), 10, radial=False).eval()
    images = torch.rand(2, 10, 112, 112)
    with torch.no_grad():
        a, b = model(images, torch.zeros(2, 9)), model(images, torch.ones(2, 9))
    assert not torch.allclose(a, b)


def test_inputs_from_a_loader_batch():
    from odms_data.loaders.sources import GeneratedExamples
    from odms_data.loaders.transforms import Transform

    assert transform(5, radial=True) == Transform(n_obs=5, radial=True)  # the loaders' default, the paper's

    batch = {k: torch.from_numpy(np.asarray(v)) for k, v in
             GeneratedExamples(seed=1, transform=transform(5, radial=True)).batch([0, 1]).items()}
    assert batch["masks"].dtype == torch.float32 and 0 < batch["masks"].max() <= 1
    images, zbar = inputs(batch, VARIANTS["odn-l"])
    assert images.shape == (2, 6, 112, 112) and torch.equal(images[:, 5], batch["radial"][:, 0])
    assert torch.equal(zbar, batch["zbar"]) and zbar.shape == (2, 3)
    _, dz = inputs(batch, VARIANTS["odn-d"])
    assert torch.equal(dz, batch["dz"]) and dz.shape == (2, 4)  # the loaders' dz_2 .. dz_n as they are
    assert build(VARIANTS["odn-d"], 5, radial=True)(images, dz).shape == (2,)


def test_bad_variant_or_observations():
    with pytest.raises(InputError, match="unknown model 'odn-x'; choose from odn-l, odn-dbar, odn-d"):
        variant("odn-x")
    with pytest.raises(InputError, match="at least 2 observations"):
        build(variant("odn-l"), 1, radial=False)


def test_curves_show_each_validation_and_explain_large_percent_errors(tmp_path):
    """Two validations are two visible points, not a bare line, and the figure says why a training
    error runs into the hundreds of percent."""
    from odms_data.network.curves import draw, figure
    from odms_data.network.run_folder import CURVES, RunFolder, TrainConfig

    folder = RunFolder(tmp_path / "run")
    folder.create(TrainConfig(val=("v.zarr",), val_every=2, iterations=4), overwrite=False)
    rows = ["iteration,seconds,set,loss,percent_error"]
    rows += [f"{i},{i},train,{1 / i},{300 / i}" for i in range(1, 5)]
    rows += [f"{i},{i},{name},{0.5 / i},{40 / i}" for i in (2, 4) for name in ("tiny-val", "val")]
    folder.file(CURVES).write_text("\n".join(rows) + "\n")
    fig = figure(folder)
    validation = [line for ax in fig.axes for line in ax.get_lines() if "validation" in line.get_label()]
    assert len(validation) == 2 and all(len(line.get_xdata()) == 2 for line in validation)
    assert all(line.get_marker() not in ("None", "", None) for line in validation)
    note = " ".join(t.get_text() for t in fig.texts)
    assert "hundreds" in note and "200 %" in note
    assert "%" in fig.axes[1].get_ylabel()
    assert draw(folder).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
