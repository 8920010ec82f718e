"""Box examples through every loader's stream: DBox's inputs, the same batches in NumPy (in
process and with workers), PyTorch (with DataLoader workers), TensorFlow and grain for one seed;
and a store's examples as box inputs, alike in every loader."""

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


def test_a_mask_store_gives_box_inputs_alike_in_every_framework(tmp_path):
    """A store of masks read as box examples (store/boxes.example_boxes) through each loader."""
    from odms_data.loaders import store_batches
    from odms_data.loaders.grain_loader import StoreSource
    from odms_data.loaders.tf_loader import from_store
    from odms_data.loaders.torch_loader import StoreDataset
    from odms_data.simulate.generate_store import generate
    from odms_data.simulate.params import GeneratorParams
    from odms_data.store.box_rule import example_boxes
    from odms_data.store.reader import open_store

    path = str(tmp_path / "s.zarr")
    small = GeneratorParams(image_size=(120, 160), sizes=(30, 60, 90))
    generate(path, 6, small, seed=3, split="s", workers=1)
    with open_store(path) as s:
        e = example_boxes(s, np.arange(6))
    want = DBOX_TRANSFORM.batch(e.boxes, e.move, e.depth)
    numpy0 = list(store_batches(path, 3, transform=DBOX_TRANSFORM))
    assert np.array_equal(np.concatenate([b["inputs"] for b in numpy0]), want["inputs"])
    assert np.array_equal(np.concatenate([b["index"] for b in numpy0]), np.arange(6))
    torch2 = [{k: v.numpy() for k, v in b.items()}
              for b in DataLoader(StoreDataset(path, DBOX_TRANSFORM), batch_size=3, num_workers=2)]
    tf_batches = [{k: v.numpy() for k, v in b.items()} for b in from_store(path, 3, transform=DBOX_TRANSFORM)]
    grain = StoreSource(path, DBOX_TRANSFORM)
    grain_batches = [{k: np.stack([grain[i][k] for i in rows]) for k in numpy0[0]}
                     for rows in ([0, 1, 2], [3, 4, 5])]
    for other in (torch2, tf_batches, grain_batches):
        assert _same(numpy0, other)
