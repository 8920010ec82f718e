"""The NumPy loader feeding JAX."""

from __future__ import annotations

import jax
import numpy as np
import pytest

from odms_data.loaders import stream_batches


def test_batches_go_to_device():
    batch = next(iter(stream_batches(4, 1, seed=2)))
    on_device = jax.device_put(batch)
    masks = np.asarray(on_device["masks"])
    assert masks.shape == (4, 10, 112, 112) and masks.dtype == np.float32
    np.testing.assert_array_equal(masks, batch["masks"])
    assert float(jax.numpy.mean(on_device["d1"])) == pytest.approx(float(batch["d1"].mean()))
