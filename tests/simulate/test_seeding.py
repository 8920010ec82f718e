"""Example generators made a batch at a time equal NumPy's PCG64(SeedSequence(seed, spawn_key=(index,)))."""

import numpy as np
import pytest

from odms_data.errors import InputError
from odms_data.simulate.seeding import BATCHED_FROM, example_rngs


def numpy_rng(seed: int, index: int) -> np.random.Generator:
    return np.random.Generator(np.random.PCG64(np.random.SeedSequence(seed, spawn_key=(index,))))


@pytest.mark.parametrize("seed", [0, 1, 20200001, 2**32 - 1, 2**32, 2**70 + 3, 2**140 + 9])
def test_batched_generators_are_numpys(seed):
    rng = np.random.default_rng(seed % 2**32)
    indices = [0, 1, 2**32 - 1, 2**32, 2**33 + 7, 2**64 + 1, *rng.integers(0, 2**31, 40).tolist()]
    assert len(indices) >= BATCHED_FROM
    for index, ours in zip(indices, example_rngs(seed, indices), strict=True):
        theirs = numpy_rng(seed, index)
        assert ours.bit_generator.state == theirs.bit_generator.state, (seed, index)
        np.testing.assert_array_equal(ours.random(4), theirs.random(4))


def test_a_few_indices_give_the_same_generators_as_many():
    few = example_rngs(7, [5, 2**40])
    many = example_rngs(7, [5, 2**40] + list(range(BATCHED_FROM)))
    for a, b in zip(few, many[:2], strict=True):
        assert a.bit_generator.state == b.bit_generator.state


@pytest.mark.parametrize(("seed", "indices"), [(-1, [0] * 10), (3, [*range(9), -4])])
def test_negative_seeds_and_indices_are_refused(seed, indices):
    with pytest.raises(InputError, match="non-negative"):
        example_rngs(seed, indices)
