"""The counter-based draws of the box generator (simulate/counter_draws.py)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.stats import kstest

from odms_data.errors import InputError
from odms_data.simulate import counter_draws

MASK = (1 << 64) - 1


def splitmix64(state: int, count: int) -> list[int]:
    """SplitMix64 as published (Steele, Lea & Flood 2014; Vigna's splitmix64.c), in Python ints."""
    out = []
    for _ in range(count):
        state = (state + 0x9E3779B97F4A7C15) & MASK
        z = state
        z = ((z ^ (z >> 30)) * 0xBF58476D1CE4E5B9) & MASK
        z = ((z ^ (z >> 27)) * 0x94D049BB133111EB) & MASK
        out.append(z ^ (z >> 31))
    return out


def test_mix64_is_splitmix64s_output_function():
    assert splitmix64(0, 1) == [0xE220A8397B1DCDAF]  # the published first output from state 0
    states = [(k * 0x9E3779B97F4A7C15) & MASK for k in range(1, 6)]
    mixed = counter_draws.mix64(np.array(states, np.uint64))
    assert [int(v) for v in mixed] == splitmix64(0, 5)


def test_a_draw_depends_on_seed_index_and_counter_alone():
    keys = counter_draws.example_keys(7, [5, 0, 3])
    whole = counter_draws.draws(counter_draws.example_keys(7, range(6)), 0, 9)
    np.testing.assert_array_equal(counter_draws.draws(keys, 0, 9), whole[:, [5, 0, 3]])
    np.testing.assert_array_equal(counter_draws.draws(keys, 4, 5), whole[4:, [5, 0, 3]])
    seven = counter_draws.example_keys(7, range(6))
    assert not np.array_equal(counter_draws.example_keys(8, range(6)), seven)
    big = counter_draws.example_keys(2**64 + 7, range(6))  # a seed of more than one word
    assert not np.array_equal(big, seven)
    assert len(np.unique(counter_draws.example_keys(0, range(100_000)))) == 100_000


def test_uniforms_and_normals_have_their_distributions():
    keys = counter_draws.example_keys(1, range(20_000))
    u = counter_draws.uniforms(keys, 0, 5)
    assert u.min() >= 0 and u.max() < 1
    assert kstest(u.ravel(), "uniform").pvalue > 1e-3
    g = counter_draws.normals(keys, 5, 7)
    assert g.shape == (7, 20_000)
    assert kstest(g.ravel(), "norm").pvalue > 1e-3
    assert abs(np.corrcoef(g[0], g[1])[0, 1]) < 0.03  # a pair's two normals are independent
    assert abs(np.corrcoef(u[0], u[1])[0, 1]) < 0.03


def test_negative_seeds_and_indices_refused():
    with pytest.raises(InputError, match="non-negative"):
        counter_draws.example_keys(-1, [0])
    with pytest.raises(InputError, match="non-negative"):
        counter_draws.example_keys(0, [3, -2])
