"""The three labels and their conversions back to a depth: label -> output -> depth is d1."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from odms_data.errors import InputError
from odms_data.loaders.targets import depth, labels


def test_labels_by_hand():
    got = labels(0.2, np.array([0.2, 0.3, 0.5, 0.6]))  # span 0.4, d_n = 0.6
    np.testing.assert_allclose([got["d1"], got["d1_norm"], got["scale"]], [0.2, 0.5, 1 / 3], rtol=1e-6)


@pytest.mark.parametrize("label", ["d1", "d1_norm", "scale"])
def test_each_label_converts_back_to_its_depth(label):
    rng = np.random.default_rng(3)
    d1 = rng.uniform(0.1, 50, 1000)
    span = d1 * rng.uniform(0.02, 2, 1000)  # scale <= 0.98: a float32 label keeps 5 digits of d1
    z = np.stack([d1, d1 + span / 3, d1 + span], axis=1)
    out = np.array([labels(d, zz)[label] for d, zz in zip(d1, z, strict=True)], np.float64)
    np.testing.assert_allclose(depth(label, out, span), d1, rtol=1e-5)
    as_tensor = depth(label, torch.tensor(out), torch.tensor(span))
    np.testing.assert_allclose(as_tensor.numpy(), d1, rtol=1e-5)


def test_scale_outputs_map_monotonically_onto_depths():
    s = np.array([0.0, 0.25, 0.5, 0.75])
    np.testing.assert_allclose(depth("scale", s, 0.3), [0, 0.1, 0.3, 0.9])  # d1 = s span / (1 - s)


def test_unknown_label():
    with pytest.raises(InputError, match="unknown label 'depth'"):
        depth("depth", 1.0, 1.0)
