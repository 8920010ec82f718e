"""Box examples through every loader's stream: DBox's inputs, the same batches in NumPy (in
process and with workers), PyTorch (with DataLoader workers), TensorFlow and grain for one seed."""

from __future__ import annotations

import numpy as np
import pytest
from torch.utils.data import DataLoader

from odms_data.errors import InputError
from odms_data.loaders import Transform, stream_batches
from odms_data.loaders.box_transform import DBOX_TRANSFORM, BoxTransform
from odms_data.loaders.grain_loader import stream_dataset
from odms_data.loaders.tf_loader import from_generator
from odms_data.loaders.torch_loader import StreamDataset
from odms_data.simulate.box_examples import BOX_PRESETS, sample_box_examples

ODMD = BOX_PRESETS["odmd"]
SIZE, BATCHES, SEED = 8, 3, 5


def _same(a, b) -> bool:
    return len(a) == len(b) and all(
        a_k.keys() == b_k.keys() and all(np.array_equal(np.asarray(a_k[k]), np.asarray(b_k[k])) for k in a_k)
        for a_k, b_k in zip(a, b, strict=True)
    )


def test_stream_batches_are_the_transformed_generator_examples():
    batches = list(stream_batches(SIZE, BATCHES, params=ODMD, seed=SEED))
    assert batches[0]["inputs"].shape == (SIZE, 10, 7) and batches[0]["inputs"].dtype == np.float32
    assert batches[1]["index"].tolist() == list(range(SIZE, 2 * SIZE))
    g = sample_box_examples(ODMD, SEED, [9])
    one = DBOX_TRANSFORM(g["boxes"][0], g["move"][0], g["depth"][0])
    assert all(np.array_equal(batches[1][k][1], one[k]) for k in one)


def test_every_framework_gives_the_same_batches():
    numpy0 = list(stream_batches(SIZE, BATCHES, params=ODMD, seed=SEED))
    numpy2 = list(stream_batches(SIZE, BATCHES, params=ODMD, seed=SEED, workers=2))
    ds = StreamDataset(SIZE, BATCHES, params=ODMD, seed=SEED)
    torch2 = [{k: v.numpy() for k, v in b.items()} for b in DataLoader(ds, batch_size=None, num_workers=2)]
    tf_ds = from_generator(SIZE, BATCHES, params=ODMD, seed=SEED)
    tf_batches = [{k: v.numpy() for k, v in b.items()} for b in tf_ds]
    grain_batches = list(stream_dataset(SIZE, BATCHES, params=ODMD, seed=SEED))
    for other in (numpy2, torch2, tf_batches, grain_batches):
        assert _same(numpy0, other)
    assert not _same(numpy0, list(stream_batches(SIZE, BATCHES, params=ODMD, seed=SEED + 1)))


def test_transform_and_kind_must_agree():
    with pytest.raises(InputError, match="BoxTransform"):
        stream_batches(SIZE, 1, params=ODMD, transform=Transform(n_obs=5))
    with pytest.raises(InputError, match="box generator parameters"):
        stream_batches(SIZE, 1, transform=BoxTransform())
    with pytest.raises(InputError, match="n_obs=12 for an example of 10"):
        stream_batches(SIZE, 1, params=ODMD, transform=BoxTransform(n_obs=12))
    absolute = next(iter(stream_batches(SIZE, 1, params=ODMD, transform=BoxTransform(normalized=False))))
    assert np.all(absolute["norm"] == 1) and np.array_equal(absolute["depth_norm"], absolute["depth"])
