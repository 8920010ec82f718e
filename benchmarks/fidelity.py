"""How close the generated splits are to the official ones: sim-val against normal-val and
sim-perturb-val against perturb-val.

    python benchmarks/fidelity.py --data odms-stores/ [--sim sim-stores/] [--examples 2000]

`--data` holds the imported official stores (`odms-data import odms`); `--sim` the generated
sim-val and sim-perturb-val, made there with `generate --split` when absent (or pass stores made
by another version of the generator). For the first `--examples` examples of each, per example:
d1, the camera move z_n - z_1, the mask area at z_1, (a_n / a_1) / (z_1 / z_n)^2 (1 for areas
exactly proportional to 1 / z^2; a boundary of constant width raises it), the compactness
perimeter^2 / area at z_1 (the perimeter: the length of the mask's outer contours,
cv2.findContours and cv2.arcLength), VOS-DE's percent error |d1_hat - d1| / d1 * 100; and per
mask whether it has a hole (scipy.ndimage.binary_fill_holes changes it). For each: the
two-sample Kolmogorov-Smirnov statistic D (scipy.stats.ks_2samp), its 5 % critical value
1.358 * sqrt((n + m) / (n m)), and the two means. Empty masks give no ratio or compactness.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import cv2
import numpy as np
import scipy.ndimage
import scipy.stats

from odms_data.evaluation.ground_truth import data_locations, find_stores
from odms_data.evaluation.vosde import vosde
from odms_data.simulate.generate_store import generate
from odms_data.simulate.params import GeneratorParams, preset
from odms_data.store.manifests import check_against_manifest, load_manifest
from odms_data.store.reader import Store, open_store

sys.path.insert(0, str(Path(__file__).resolve().parent))
import _results  # noqa: E402

PAIRS = (("sim-val", "normal-val"), ("sim-perturb-val", "perturb-val"))
C_ALPHA = 1.358  # sqrt(-ln(0.05 / 2) / 2): the asymptotic 5 % critical value of D, times sqrt(n m / (n + m))
STATISTICS = {
    "d1": "d1 (m)",
    "move": "camera move z_n - z_1 (m)",
    "area": "mask area at z_1 (px)",
    "ratio": "(a_n / a_1) / (z_1 / z_n)^2",
    "compactness": "compactness perimeter^2 / area at z_1",
    "hole": "masks with a hole (fraction)",
    "vosde": "VOS-DE error (%)",
}


def mask_shape(mask: np.ndarray) -> tuple[float, bool]:
    """Perimeter (outer contours) of a mask and whether it has a hole."""
    m = mask.view(np.uint8)
    x, y, w, h = cv2.boundingRect(m)
    box = np.pad(m[y : y + h, x : x + w], 1)
    contours, _ = cv2.findContours(box, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE)
    perimeter = sum(cv2.arcLength(c, True) for c in contours)
    return perimeter, bool((scipy.ndimage.binary_fill_holes(box) != box).any())


def measure(store: Store, count: int) -> dict[str, np.ndarray]:
    """The statistics of the first `count` examples of a store (holes: one value per mask)."""
    rows = range(min(count, len(store)))
    first = store.frame_index[rows, 0]
    last = np.array([store.frames_of(i)[-1] for i in rows])
    z1, zn, a1, an = store.z[first], store.z[last], store.area[first], store.area[last]
    compactness, holes = np.full(len(rows), np.nan), []
    for i in rows:
        masks = store.read_masks(store.frames_of(i))
        for j, mask in enumerate(masks):
            if not mask.any():
                holes.append(False)
                continue
            perimeter, hole = mask_shape(mask)
            holes.append(hole)
            if j == 0:
                compactness[i] = perimeter**2 / a1[i]
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.where(a1 > 0, an / a1 / (z1 / zn) ** 2, np.nan)
    d1 = store.d1[: len(rows)]
    estimate = vosde(store).d1[: len(rows)]
    return {
        "d1": d1, "move": zn - z1, "area": a1.astype(float), "ratio": ratio,
        "compactness": compactness, "hole": np.array(holes, float),
        "vosde": np.abs(estimate - d1) / d1 * 100,
    }


def compare(sim: dict[str, np.ndarray], official: dict[str, np.ndarray]) -> list[tuple]:
    """Per statistic: (label, D, critical value, sim mean, official mean, n sim, n official)."""
    out = []
    for key, label in STATISTICS.items():
        a, b = sim[key][np.isfinite(sim[key])], official[key][np.isfinite(official[key])]
        d = scipy.stats.ks_2samp(a, b).statistic
        critical = C_ALPHA * np.sqrt((len(a) + len(b)) / (len(a) * len(b)))
        out.append((label, d, critical, a.mean(), b.mean(), len(a), len(b)))
    return out


def sim_store(folder: Path, name: str, workers: int) -> Path:
    """The generated split `name` in `folder`, generated (and checked) when absent."""
    path = folder / f"{name}.zarr"
    if not path.exists():
        m = load_manifest(name)
        g = m.generator or {}
        params = GeneratorParams.from_json({**preset(g["preset"]).to_json(), **g.get("params", {})})
        print(f"generating {path} ...", flush=True)
        attrs = generate(str(path), m.count, params, g["seed"], split=name, preset=g["preset"],
                         workers=workers)
        check_against_manifest(attrs, m, str(path))
    return path


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--data", action="append", default=[], help="official stores (default: $ODMS_DATA)")
    ap.add_argument("--sim", type=Path, default=Path("."),
                    help="folder of sim-val.zarr and sim-perturb-val.zarr")
    ap.add_argument("--examples", type=int, default=2000)
    ap.add_argument("--workers", type=int, default=2, help="processes generating a missing sim store")
    _results.add_options(ap)
    args = ap.parse_args()
    official, table = find_stores(data_locations(args.data)), []
    for sim_name, official_name in PAIRS:
        if official_name not in official:
            where = args.data or "$ODMS_DATA"
            raise SystemExit(f"no {official_name} store in {where}: odms-data import odms ...")
        with open_store(str(sim_store(args.sim, sim_name, args.workers))) as s, \
                open_store(str(official[official_name])) as o:
            version = s.attrs.generator_version
            rows = compare(measure(s, args.examples), measure(o, args.examples))
        print(f"\n{sim_name} (generator version {version}) against {official_name}, "
              f"{min(args.examples, rows[0][5])} examples each\n")
        print(f"| statistic | KS D | 5 % critical | below | mean {sim_name} | mean {official_name} |")
        print("| --- | ---: | ---: | :---: | ---: | ---: |")
        for label, d, critical, mean_sim, mean_official, n_sim, n_official in rows:
            counts = "" if n_sim == n_official else f" ({n_sim} / {n_official} values)"
            print(f"| {label}{counts} | {d:.4f} | {critical:.4f} | {'yes' if d < critical else '**no**'} "
                  f"| {mean_sim:.4g} | {mean_official:.4g} |")
            table.append({"generated": f"{sim_name} (version {version})", "official": official_name,
                          "statistic": label + counts, "KS D": d, "5 % critical": critical,
                          "below": "yes" if d < critical else "no", "mean generated": mean_sim,
                          "mean official": mean_official})
    _results.save(args, "Fidelity: the generated splits against the official ones (two-sample KS tests)",
                  {"what": "the official normal-val and perturb-val sets, first examples",
                   "value": args.examples, "unit": "examples"}, table)


if __name__ == "__main__":
    main()
