"""`odms-data estimate` over a 10,000-frame recording (VOS-DE and Box_LS), against `odms-data
baseline` on the same store in the same run.

Run by hand: `python benchmarks/estimate.py`. It renders the recording with
examples/rendered_scene.py (--frames, a 0.2 mm step, no rotation), imports it with its 4x4
poses and the robot protocol's windows (10, 15, 20, 25, 30 frames, 10 observations: about 50,000
windows), then times, each the median of --repeat runs:

- end to end in a fresh interpreter (imports included): `baseline vosde|box-ls STORE -o x.csv`
  (the baseline) and `estimate STORE --method vosde|box-ls -o OUT`, which also aggregates the
  windows per frame, writes frames.csv and scores the labelled store;
- in this process, the parts of `estimate`: the method alone, the per-frame aggregation
  (frame_depths), writing the folder, and the score.

Only speed is measured here: over 0.2 mm steps the windows' estimates are not meaningful (the
rendered scene's accuracy is tests/cli/test_estimate.py's).
"""

from __future__ import annotations

import argparse
import statistics
import subprocess
import sys
import tempfile
import timeit
from collections.abc import Callable
from pathlib import Path

from odms_data.evaluation.box_ls import box_ls
from odms_data.evaluation.evaluate import Evaluation
from odms_data.evaluation.frame_depths import EXAMPLES, frame_depths, write_estimate
from odms_data.evaluation.vosde import vosde
from odms_data.store.reader import open_store

sys.path.insert(0, str(Path(__file__).resolve().parent))
import _results  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
EXAMPLE = ROOT / "examples" / "rendered_scene.py"
ODMS = [sys.executable, "-m", "odms_data.cli"]
METHODS = {"vosde": vosde, "box-ls": box_ls}


def median_time(fn: Callable[[], object], repeat: int) -> float:
    return statistics.median(timeit.repeat(fn, number=1, repeat=repeat))


def run(args: list[str]) -> None:
    subprocess.run(args, check=True, capture_output=True, cwd=ROOT)


def make_store(tmp: Path, frames: int) -> Path:
    scene = tmp / "scene"
    run([sys.executable, str(EXAMPLE), "-o", str(scene), "--frames", str(frames), "--step", "0.0002",
         "--rotation", "0"])
    store = tmp / "scene.zarr"
    run([*ODMS, "import", "recording", str(scene / "masks"), "--poses", str(scene / "poses.txt"), "--d1",
         "0.3", "--windows", "10,15,20,25,30", "-o", str(store)])
    return store


def parts(store: Path, method: str, tmp: Path, repeat: int) -> dict[str, float]:
    """Seconds of each part of `estimate` in this process."""
    with open_store(str(store)) as s:
        n = int(s.n_obs.min())
        t_method = median_time(lambda: METHODS[method](s, n), repeat)
        r = METHODS[method](s, n)
        t_frames = median_time(lambda: frame_depths(s, r.d1, r.unsolvable), repeat)
        depths = frame_depths(s, r.d1, r.unsolvable)
        split, ids = s.attrs.split, s.example_ids
    out = tmp / f"parts-{method}"
    t_write = median_time(lambda: write_estimate(out, split, ids, r.d1, depths, overwrite=True), repeat)
    t_score = median_time(lambda: Evaluation([str(store)]).score(out / EXAMPLES, intervals=False), repeat)
    return {"method": t_method, "per-frame aggregation": t_frames, "writing the folder": t_write,
            "score": t_score}


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--frames", type=int, default=10_000)
    p.add_argument("--repeat", type=int, default=3)
    _results.add_options(p)
    a = p.parse_args()
    rows = []
    with tempfile.TemporaryDirectory() as t:
        tmp = Path(t)
        store = make_store(tmp, a.frames)
        with open_store(str(store)) as s:
            windows, frames = s.n_examples, s.n_frames
        print(f"{frames} frames, {windows} windows")
        baseline = {}
        for method in METHODS:
            base = median_time(lambda m=method: run([*ODMS, "baseline", m, str(store), "-o",
                                                     str(tmp / "b.csv"), "--overwrite"]), a.repeat)
            est = median_time(lambda m=method: run([*ODMS, "estimate", str(store), "--method", m, "-o",
                                                    str(tmp / "est"), "--overwrite"]), a.repeat)
            baseline[method] = base
            rows.append({"measurement": f"`baseline {method}` end to end", "seconds": base, "ratio": 1.0,
                         "against": "itself"})
            rows.append({"measurement": f"`estimate --method {method}` end to end (with the score)",
                         "seconds": est, "ratio": est / base, "against": f"baseline {method}"})
            for part, sec in parts(store, method, tmp, a.repeat).items():
                rows.append({"measurement": f"{method}: {part} (in process)", "seconds": sec, "ratio": None,
                             "against": ""})
    print("\n| measurement | seconds | ratio |\n|---|---:|---:|")
    for r in rows:
        ratio = "" if r["ratio"] is None else f"{r['ratio']:.2f}x {r['against']}"
        print(f"| {r['measurement']} | {r['seconds']:.3f} | {ratio} |")
    _results.save(a, f"estimate over a {a.frames:,}-frame recording",
                  {"what": "`odms-data baseline vosde` on the same store", "value": baseline["vosde"],
                   "unit": "s"},
                  rows, {"frames": frames, "windows": windows, "repeat": a.repeat,
                         "baseline_box_ls_s": baseline["box-ls"]})


if __name__ == "__main__":
    main()
