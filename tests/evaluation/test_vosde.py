"""VOS-DE: exact on ideal masks, the released code's degenerate cases, and the golden figures."""

from __future__ import annotations

import numpy as np
import pytest
from _stores import make_store
from click.testing import CliRunner

from odms_data.cli import main
from odms_data.errors import InputError
from odms_data.evaluation.predictions import read_predictions
from odms_data.evaluation.vosde import solve, vosde
from odms_data.protocol import observation_indices
from odms_data.simulate.generate_store import generate
from odms_data.simulate.params import preset
from odms_data.store.manifests import load_manifest
from odms_data.store.masks import mask_stats
from odms_data.store.reader import open_store

# VOS-DE, n = 10, on the official splits: the released code on the released data (to 0.1).
# Test driving is 35.76 here and in the released code; the paper prints 36.0.
GOLDEN = {
    "robot-val": 27.4, "driving-val": 35.9, "normal-val": 7.9, "perturb-val": 34.1,
    "robot-test": 32.6, "driving-test": 35.8, "normal-test": 7.9, "perturb-test": 33.6,
}
GOLDEN_ALL_TEST = 27.5
# n = 2: the paper's VOS-DE figures, which the released code also reproduces (to 0.1).
GOLDEN_N2 = {
    "robot-val": 95.8, "driving-val": 55.0, "normal-val": 8.2, "perturb-val": 90.6,
    "robot-test": 65.5, "driving-test": 41.1, "normal-test": 8.3, "perturb-test": 86.2,
}


def ideal(z, z_obj=0.0, c=60.0):
    """Areas of a square whose side is c / depth (all perfect squares for these z)."""
    return [int(round(c / (zi - z_obj))) ** 2 for zi in z]


def test_ideal_squares_give_the_exact_depth(tmp_path):
    z = [1.0, 1.2, 1.5, 2.0, 3.0, 4.0, 5.0, 6.0]  # 60 / z is an integer
    path = make_store(tmp_path / "s.zarr", "ideal", [{"z": z, "areas": ideal(z), "d1": 1.0}])
    with open_store(path) as s:
        r = vosde(s, n_obs=8)
    assert r.d1 == pytest.approx([1.0], abs=1e-12)
    assert not r.unsolvable.any() and not r.flagged.any()


def test_estimate_is_relative_to_the_first_observation(tmp_path):
    z = np.array([1.0, 1.2, 1.5, 2.0, 3.0])
    areas = ideal(z)
    path = make_store(tmp_path / "s.zarr", "shifted", [{"z": z + 7.0, "areas": areas, "d1": 1.0}])
    with open_store(path) as s:
        assert vosde(s, n_obs=5).d1 == pytest.approx([1.0], abs=1e-12)


def test_singular_systems_predict_zero_and_are_counted(tmp_path):
    examples = [
        {"z": [0.1, 0.2, 0.3], "areas": [0, 0, 0], "d1": 0.1},  # all masks empty
        {"z": [0.1, 0.2, 0.3], "areas": [400, 400, 400], "d1": 0.1},  # no change in area
        {"z": [0.1, 0.2, 0.3], "areas": [400, 0, 100], "d1": 0.1},  # one empty mask: solvable
    ]
    path = make_store(tmp_path / "s.zarr", "degenerate", examples)
    with open_store(path) as s:
        r = vosde(s, n_obs=3)
    assert r.unsolvable.tolist() == [True, True, False]
    assert r.flagged.tolist() == [True, False, True]
    assert r.d1[:2].tolist() == [0.0, 0.0] and r.d1[2] != 0.0
    out = tmp_path / "p.csv"
    res = CliRunner().invoke(main, ["baseline", "vosde", path, "--n-obs", "3", "-o", str(out)])
    assert res.exit_code == 0, res.output
    assert ("degenerate: 3 examples, 2 unsolvable (predicted 0), 0 ill-conditioned, 2 with an empty "
            "mask") in res.stdout
    res = CliRunner().invoke(main, ["score", str(out), "--data", path, "--json"])
    assert res.exit_code == 0, res.output


def test_solve_matches_numpy_least_squares():
    rng = np.random.default_rng(0)
    s, dz = rng.uniform(10, 200, (50, 10)), np.sort(rng.uniform(0, 0.5, (50, 10)), axis=1)
    d1, bad, ill = solve(s, dz)
    assert not bad.any() and not ill.any()
    for i in range(50):
        A = np.stack([s[i], np.ones(10)], axis=1)
        x, *_ = np.linalg.lstsq(A, dz[i] * s[i], rcond=None)
        assert d1[i] == pytest.approx(-x[0], rel=1e-9)
    assert not bad.any()


def test_observation_choice_is_linspace_truncated():
    assert observation_indices(30, 10).tolist() == [0, 3, 6, 9, 12, 16, 19, 22, 25, 29]
    assert observation_indices(10, 10).tolist() == list(range(10))
    with pytest.raises(InputError, match="got n_obs=10 for an example of 7 frames"):
        observation_indices(7, 10)
    assert observation_indices(10, 2).tolist() == [0, 9]


def test_stored_statistics_give_the_same_estimates_as_decoding_masks(tmp_path):
    params = preset("perturb")
    path = str(tmp_path / "p.zarr")
    generate(path, 60, params, seed=5, split="pert")
    with open_store(path) as s:
        fast = vosde(s, n_obs=5)
        for i in range(s.n_examples):
            ex = s.example(i)
            areas = np.array([mask_stats(m)[1] for m in ex.masks], np.float64)
            cols = observation_indices(ex.n, 5)
            d1, _, _ = solve(np.sqrt(areas[cols])[None], (ex.z[cols] - ex.z[0])[None])
            assert fast.d1[i] == pytest.approx(d1[0], rel=1e-12)


@pytest.fixture(scope="module")
def sim_scores(tmp_path_factory):
    """VOS-DE mean percent error on the generated sim-val and sim-perturb-val."""
    out = {}
    for name in ("sim-val", "sim-perturb-val"):
        m = load_manifest(name)
        path = str(tmp_path_factory.mktemp("sim") / f"{name}.zarr")
        params = preset(m.generator["preset"])
        generate(path, m.count, params, m.generator["seed"], split=name, workers=2)
        with open_store(path) as s:
            out[name] = float((np.abs(s.d1 - vosde(s).d1) / s.d1).mean() * 100)
    return out


def test_generated_sim_val_is_close_to_official_normal_val(sim_scores):
    assert abs(sim_scores["sim-val"] - GOLDEN["normal-val"]) <= 1.0, sim_scores


def test_generated_sim_perturb_val_is_close_to_official_perturb_val(sim_scores):
    assert abs(sim_scores["sim-perturb-val"] - GOLDEN["perturb-val"]) <= 3.0, sim_scores


@pytest.fixture(scope="module")
def official(official_stores):
    return official_stores


@pytest.mark.parametrize("n_obs, golden", [(10, GOLDEN), (2, GOLDEN_N2)])
def test_golden_vosde_on_the_official_splits(official, tmp_path, n_obs, golden):
    """The benchmark's meaning: baseline vosde + score reproduce the released code's figures."""
    data = str(next(iter(official.values())).parent)
    preds = tmp_path / "vosde.csv"
    args = ["baseline", "vosde", "--data", data, "--n-obs", str(n_obs), "-o", str(preds)]
    r = CliRunner().invoke(main, args)
    assert r.exit_code == 0, r.output
    assert len(read_predictions(preds)) == 15650
    r = CliRunner().invoke(main, ["score", str(preds), "--data", data, "--json"])
    assert r.exit_code == 0, r.output
    import json

    report = json.loads(r.stdout)
    got = {s["split"]: s["mean_percent_error"] for s in report["splits"]}
    assert {k: round(v, 1) for k, v in got.items()} == golden
    if n_obs == 10:
        assert round(report["all"]["test"], 1) == GOLDEN_ALL_TEST


def test_official_ground_truth_scores_exactly_zero(official, tmp_path):
    from odms_data.evaluation.predictions import write_predictions

    rows = []
    for split, path in official.items():
        with open_store(str(path)) as s:
            rows += [(split, e, float(d)) for e, d in zip(s.example_ids, s.d1, strict=True)]
    write_predictions(tmp_path / "gt.csv", rows)
    data = str(next(iter(official.values())).parent)
    r = CliRunner().invoke(main, ["score", str(tmp_path / "gt.csv"), "--data", data, "--json"])
    assert r.exit_code == 0, r.output
    import json

    report = json.loads(r.stdout)
    assert all(s["mean_percent_error"] == 0.0 and s["mean_abs_error_m"] == 0.0 for s in report["splits"])
    assert report["all"] == {"val": 0.0, "test": 0.0}


def test_a_camera_that_never_moved_is_unsolvable():
    """Its system solved to 0 m (every dz is 0) and counted as solved."""
    sqrt_area = np.array([[10.0, 11.0, 12.5], [10.0, 11.0, 12.5]])
    dz = np.array([[0.0, 0.1, 0.2], [0.0, 0.0, 0.0]])
    d1, bad, ill = solve(sqrt_area, dz)
    assert bad.tolist() == [False, True] and d1[1] == 0.0 and not ill.any()


def test_n_obs_beyond_the_observations_is_refused_as_training_refuses_it(tmp_path):
    """--n-obs 11 on examples of 10 was reported as n = 11."""
    z = [1.0, 1.2, 1.5, 2.0, 3.0]
    path = make_store(tmp_path / "s.zarr", "short", [{"z": z, "areas": ideal(z), "d1": 1.0}])
    r = CliRunner().invoke(main, ["baseline", "vosde", path, "--n-obs", "6", "-o", str(tmp_path / "p.csv")])
    assert r.exit_code == 2, r.output
    assert r.stderr == (f"odms-data: error: {path}: example short/000: need 2 <= n_obs <= n, got n_obs=6 "
                        "for an example of 5 frames\n")
    assert not (tmp_path / "p.csv").exists()
