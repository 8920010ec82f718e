"""Does `generate --boxes --config FILE` give a config file the meaning the authors' generator gives it?

    python benchmarks/box_config_fidelity.py --odmd DIR [--examples 100000] [--seed 1]

`--odmd` is a checkout of griffbr/ODMD the user has (nothing is downloaded or copied). For each
configuration, the authors' generator (odmd/data_gen: DataGenerator, generate_object_examples,
add_perturbations, as their training demo runs it) reads the yaml files, and the box generator
reads the same files (simulate/box_config.py). The configurations: the authors'
standard_data.yaml with the HSR camera, their ODMS.yaml with the ODMS camera, and a file of
other values for every key, written here, with a camera of other values. For each of
box_distributions.py's ten per-example statistics, a two-sample Kolmogorov-Smirnov D compares
ours with the authors' (seed `--seed`); the yardstick is the authors' generator against itself
(seeds `--seed` and `--seed` + 1). Baseline: the largest seed-to-seed D of the run.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
from scipy.stats import ks_2samp

from odms_data.simulate.box_config import read_box_config
from odms_data.simulate.box_examples import sample_box_examples

sys.path.insert(0, str(Path(__file__).resolve().parent))
import _results  # noqa: E402
from box_distributions import statistics  # noqa: E402

OTHER_DATA = """data_description: other values for every key (odms-data's check)
z_lim: [1.0, 2.0]
move_min: [0.02, 0, 0.1]
move_max: [0.1, 0.15, 0.5]
size_lim: [0.05, 0.2]
num_pos: 6
perturb: True
std_dev: 0.003
cam_dev: 0.02
shuffle: 0.3
end_swap: False
"""
OTHER_CAMERA = """camera_name: another pinhole camera
image_dim: [360, 640]
fx: 300.0
fy: 280.0
cx: 330.0
cy: 170.0
"""

# their modules import IPython, stubbed here when absent; the arrays come back as one .npz
AUTHORS = """
import sys, types
import numpy as np
sys.modules.setdefault("IPython", types.SimpleNamespace(embed=lambda: None))
repo, data, camera, count, seed, out = sys.argv[1:]
sys.path.insert(0, repo)
import odmd
g = odmd.data_gen.DataGenerator(data)
g.initialize_data_gen(camera)
np.random.seed(int(seed))
b3, bb = g.generate_object_examples(int(count))
b3, bb = odmd.data_gen.add_perturbations(b3, bb, g)
np.savez(out, bboxes=bb["bboxes"], camera_movement=b3["camera_movement"])
"""


def authors(repo: str, files: list[str], count: int, seed: int, tmp: Path) -> dict[str, np.ndarray]:
    """The statistics of `count` examples of the authors' generator reading `files` (data, camera)."""
    out = tmp / f"authors-{seed}.npz"
    subprocess.run([sys.executable, "-c", AUTHORS, repo, *files, str(count), str(seed), str(out)], check=True)
    d = np.load(out)
    bb, cam = d["bboxes"], d["camera_movement"]
    move = np.zeros((bb.shape[2], bb.shape[0], 3))
    move[:, :-1] = cam.transpose(2, 0, 1)
    return statistics(bb[:, :4, :].transpose(2, 0, 1), move, bb[-1, 4, :])


def ours(files: list[str], count: int, seed: int) -> dict[str, np.ndarray]:
    g = sample_box_examples(read_box_config(files), seed, np.arange(count))
    return statistics(g["boxes"], g["move"], g["depth"])


def _d(a: np.ndarray, b: np.ndarray) -> float:
    return float(ks_2samp(a[np.isfinite(a)], b[np.isfinite(b)]).statistic)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--odmd", required=True, help="a checkout of griffbr/ODMD")
    ap.add_argument("--examples", type=int, default=100_000)
    ap.add_argument("--seed", type=int, default=1)
    _results.add_options(ap)
    a = ap.parse_args()
    repo = str(Path(a.odmd).resolve())
    rows = []
    with tempfile.TemporaryDirectory() as tmp_dir:
        tmp = Path(tmp_dir)
        (tmp / "other_data.yaml").write_text(OTHER_DATA)
        (tmp / "other_camera.yaml").write_text(OTHER_CAMERA)
        configs = {
            "standard_data + hsr_grasp_camera": [f"{repo}/config/data_gen/standard_data.yaml",
                                                 f"{repo}/config/camera/hsr_grasp_camera.yaml"],
            "ODMS + ODMS_camera": [f"{repo}/config/data_gen/ODMS.yaml",
                                   f"{repo}/config/camera/ODMS_camera.yaml"],
            "other values for every key": [str(tmp / "other_data.yaml"), str(tmp / "other_camera.yaml")],
        }
        for name, files in configs.items():
            theirs = authors(repo, files, a.examples, a.seed, tmp)
            again = authors(repo, files, a.examples, a.seed + 1, tmp)
            mine = ours(files, a.examples, a.seed)
            for stat in theirs:
                rows.append({"config": name, "statistic": stat,
                             "ours_vs_authors_D": _d(mine[stat], theirs[stat]),
                             "authors_seed_to_seed_D": _d(again[stat], theirs[stat])})
                print(rows[-1])
    worst = {k: max(r[k] for r in rows) for k in ("ours_vs_authors_D", "authors_seed_to_seed_D")}
    print(worst)
    _results.save(a, "generate --boxes --config: the authors' generator and ours reading the same files",
                  {"what": "the largest authors-vs-authors (seed to seed) KS D",
                   "value": worst["authors_seed_to_seed_D"], "unit": "D"},
                  rows, {"examples": a.examples, "seed": a.seed,
                         "largest_ours_vs_authors_D": worst["ours_vs_authors_D"]})


if __name__ == "__main__":
    main()
