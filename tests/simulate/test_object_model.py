"""The generator: distributions of section 5.1, projective geometry, perturbation, seeding."""

from dataclasses import replace

import numpy as np
import pytest
from _stores import stats_of

from odms_data.errors import InputError
from odms_data.simulate.object_model import sample_example, sample_examples, spaced_points
from odms_data.simulate.params import PRESETS, GeneratorParams, preset
from odms_data.simulate.render import reference_masks

STANDARD, PERTURB = PRESETS["standard"], PRESETS["perturb"]


def test_camera_positions_follow_the_papers_ranges():
    z = np.array([sample_example(STANDARD, 3, i).z for i in range(500)])
    assert z.shape == (500, 10)
    assert np.all(np.diff(z, axis=1) >= 0)
    assert z[:, 0].min() >= 0.1 and z[:, 0].max() <= 0.6
    assert np.all(z[:, -1] - z[:, 0] >= 0.1 - 1e-12) and z[:, -1].max() <= 0.7
    # z_1 ~ U[0.1, 0.6]: its mean is near 0.35
    assert abs(z[:, 0].mean() - 0.35) < 0.02


def test_mask_areas_follow_inverse_square_of_depth():
    for i in range(40):
        spec = sample_example(STANDARD, 11, i)
        masks = reference_masks(spec, STANDARD)
        stats = stats_of(masks)
        a = stats.area.astype(float)
        half_perimeter = (stats.bbox[:, 2] - stats.bbox[:, 0]) + (stats.bbox[:, 3] - stats.bbox[:, 1])
        ratio = (spec.z[0] / spec.z) ** 2
        expected = a[0] * ratio
        # discretisation: at most about one boundary pixel per unit of outline, in each frame
        tolerance = half_perimeter + half_perimeter[0] * ratio
        assert np.all(np.abs(a - expected) <= tolerance), (i, a, expected, tolerance)


def test_object_is_centred_and_one_region():
    spec = sample_example(STANDARD, 2, 0)
    stats = stats_of(reference_masks(spec, STANDARD))
    cx = (stats.bbox[:, 0] + stats.bbox[:, 2]) / 2
    cy = (stats.bbox[:, 1] + stats.bbox[:, 3]) / 2
    # the contour's s_p box is centred, so the object's own box lies around the centre
    assert np.all(np.abs(cx - 320) < 200) and np.all(np.abs(cy - 240) < 200)
    assert np.all(stats.largest_area > 0)


def test_perturbation_erodes_or_dilates_by_the_drawn_iterations():
    spec = sample_example(PERTURB, 5, 1)
    plain = reference_masks(replace(spec, perturb=np.zeros(10)), PERTURB).reshape(10, -1).sum(1)
    perturbed = reference_masks(spec, PERTURB).reshape(10, -1).sum(1)
    k = np.round(np.abs(spec.perturb))
    for i in range(10):
        if k[i] == 0:
            assert perturbed[i] == plain[i]
        elif spec.perturb[i] > 0:
            assert perturbed[i] > plain[i]
        else:
            assert perturbed[i] < plain[i]
    draws = np.concatenate([sample_example(PERTURB, 5, i).perturb for i in range(300)])
    assert abs(draws.std() - 1.0) < 0.1 and abs(draws.mean()) < 0.1


def test_same_seed_and_index_give_the_same_example_whatever_the_order():
    a = sample_example(STANDARD, 9, 123)
    for i in range(5):
        sample_example(STANDARD, 9, i)
    b = sample_example(STANDARD, 9, 123)
    np.testing.assert_array_equal(a.z, b.z)
    np.testing.assert_array_equal(a.contour, b.contour)
    c = sample_example(STANDARD, 10, 123)
    assert not np.array_equal(a.z, c.z)


def test_an_example_is_the_same_whatever_else_is_sampled_with_it():
    params = replace(PERTURB, n_points=(3, 4, 9, 10), spacing_tries=5)  # the last try kept, often
    indices = [17, 3, 250, 3, 0, 41, 8, 99, 5, 12, 64, 7]
    together = sample_examples(params, 6, indices)
    for index, spec in zip(indices, together, strict=True):
        alone = sample_example(params, 6, index)
        for key in ("z", "contour", "perturb"):
            np.testing.assert_array_equal(getattr(spec, key), getattr(alone, key))
        assert spec.size == alone.size


@pytest.mark.parametrize(("n", "tries"), [(3, 201), (7, 201), (10, 201), (10, 2), (6, 1)])
def test_tries_drawn_in_blocks_match_drawing_one_at_a_time(n, tries):
    """The generator is stepped back over the tries drawn after the one kept."""
    for seed in range(40):
        one, block = np.random.default_rng(seed), np.random.default_rng(seed)
        for _ in range(tries):
            pts = one.random((n, 2))
            c = pts.mean(axis=0)
            pts = pts[np.argsort(np.arctan2(pts[:, 1] - c[1], pts[:, 0] - c[0]))]
            steps = np.diff(pts, axis=0)
            if np.abs(steps[:, 0] + steps[:, 1]).min() >= 0.7 / n:
                break
        np.testing.assert_array_equal(spaced_points(block, n, 0.7 / n, tries), pts)
        np.testing.assert_array_equal(block.normal(size=3), one.normal(size=3))


def test_points_are_spaced_by_the_released_generators_rule():
    rng = np.random.default_rng(0)
    wrap_gaps = []
    for n in (3, 6, 10):
        for _ in range(20):
            pts = spaced_points(rng, n, 0.7 / n, 201)
            steps = np.diff(pts, axis=0)
            assert np.abs(steps[:, 0] + steps[:, 1]).min() >= 0.7 / n
            wrap = pts[0] - pts[-1]
            wrap_gaps.append(abs(wrap[0] + wrap[1]) / (0.7 / n))
    assert min(wrap_gaps) < 1  # the gap from the last point back to the first is not checked


def test_rendering_at_training_resolution_keeps_the_object_centred():
    spec = sample_example(STANDARD, 4, 2)
    small = reference_masks(spec, STANDARD, size=(112, 112))
    assert small.shape == (10, 112, 112)
    full = reference_masks(spec, STANDARD).reshape(10, -1).sum(1)
    scale = (112 / 480) * (112 / 640)
    np.testing.assert_allclose(small.reshape(10, -1).sum(1), full * scale, rtol=0.35, atol=20)


@pytest.mark.parametrize("bad", [
    {"n_obs": 1}, {"d_min": 0.8}, {"dz_min": 0.9}, {"sizes": ()}, {"perturb_std": -1},
])
def test_inconsistent_parameters_are_refused(bad):
    with pytest.raises(InputError, match="generator parameters"):
        preset("standard", **bad)


def test_parameters_round_trip_through_json():
    p = GeneratorParams(n_obs=5, sizes=(50, 60), perturb_std=0.5)
    assert GeneratorParams.from_json(p.to_json()) == p
    with pytest.raises(InputError, match="unknown name"):
        GeneratorParams.from_json({"nobs": 3})
