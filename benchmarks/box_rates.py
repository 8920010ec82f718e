"""Box examples against mask examples: generation and streaming rates, measured in one run.

Run by hand: `python benchmarks/box_rates.py [--count 2000] [--batch 256] [--odmd DIR]`. Times, as
the median of --repeat runs, in examples per second on one process:

- `generate`: drawing --count examples (simulate.box_examples for boxes; object_model and
  batch_render at the store's full size for masks);
- `stream`: loaders.stream_batches, batches of --batch of the network inputs (DBox's for boxes,
  ODN's 112x112 masks for masks), in process;
- with --odmd DIR, a checkout of griffbr/ODMD the user has (nothing is downloaded or copied): its
  released generator (standard_data.yaml, HSR camera, perturbations) making --count examples in
  one call, as its training demo does a batch.

Writes benchmarks/results/box_rates.json (_results.py), the mask examples' generation rate as the
baseline.
"""

from __future__ import annotations

import argparse
import statistics
import subprocess
import sys
import time
from pathlib import Path

from odms_data.loaders import stream_batches
from odms_data.simulate.batch_render import render_masks
from odms_data.simulate.box_examples import BOX_PRESETS, sample_box_examples
from odms_data.simulate.object_model import sample_examples
from odms_data.simulate.params import PRESETS

sys.path.insert(0, str(Path(__file__).resolve().parent))
import _results  # noqa: E402


def median_rate(fn, count: int, repeat: int) -> float:
    times = []
    for _ in range(repeat):
        t = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t)
    return count / statistics.median(times)


def odmd_generator(repo: str, count: int, repeat: int) -> float:
    """The authors' generator from the user's checkout, in a child process (their modules import
    IPython, which it stubs when absent)."""
    child = f"""
import sys, time, types, statistics
sys.modules.setdefault("IPython", types.SimpleNamespace(embed=lambda: None))
sys.path.insert(0, {repo!r})
import odmd
g = odmd.data_gen.DataGenerator({repo!r} + "/config/data_gen/standard_data.yaml")
g.initialize_data_gen({repo!r} + "/config/camera/hsr_grasp_camera.yaml")
times = []
for _ in range({repeat}):
    t = time.perf_counter()
    b3, bb = g.generate_object_examples({count})
    odmd.data_gen.add_perturbations(b3, bb, g)
    times.append(time.perf_counter() - t)
print({count} / statistics.median(times))
"""
    out = subprocess.run([sys.executable, "-c", child], capture_output=True, text=True, check=True)
    return float(out.stdout.split()[-1])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--count", type=int, default=2000, help="box examples generated per timing")
    ap.add_argument("--mask-count", type=int, default=100, help="mask examples generated per timing")
    ap.add_argument("--batch", type=int, default=256)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--odmd", help="a checkout of griffbr/ODMD, to time the authors' generator too")
    _results.add_options(ap)
    a = ap.parse_args()
    boxes, masks = BOX_PRESETS["odmd"], PRESETS["standard"]
    rates = {
        "generate_boxes": median_rate(lambda: sample_box_examples(boxes, 0, range(a.count)), a.count,
                                      a.repeat),
        "generate_masks": median_rate(
            lambda: render_masks(sample_examples(masks, 0, range(a.mask_count)), masks), a.mask_count,
            a.repeat),
        "stream_boxes": median_rate(lambda: list(stream_batches(a.batch, max(1, a.count // a.batch),
                                                                params=boxes)),
                                    a.batch * max(1, a.count // a.batch), a.repeat),
        "stream_masks": median_rate(lambda: list(stream_batches(a.mask_count, 1, params=masks)),
                                    a.mask_count, a.repeat),
    }
    if a.odmd:
        rates["generate_boxes_odmd_code"] = odmd_generator(a.odmd, a.count, a.repeat)
    cases = {"generate_boxes": ("generate", "boxes (simulate.box_examples)", a.count),
             "generate_masks": ("generate", "masks (object_model + batch_render)", a.mask_count),
             "stream_boxes": ("stream", "boxes (DBox inputs)", a.batch * max(1, a.count // a.batch)),
             "stream_masks": ("stream", "masks (ODN's 112x112 inputs)", a.mask_count),
             "generate_boxes_odmd_code": ("generate", "boxes (the authors' ODMD generator)", a.count)}
    rows = [{"what": cases[k][0], "examples": cases[k][1], "count": cases[k][2], "examples_per_s": rate,
             "over_masks": rate / rates[f"{cases[k][0]}_masks"]} for k, rate in rates.items()]
    for row in rows:
        print(row)
    _results.save(a, "Box examples against mask examples: generation and streaming rates",
                  {"what": "generating mask examples", "value": rates["generate_masks"],
                   "unit": "examples/s"},
                  rows, {"batch": a.batch, "repeat": a.repeat})


if __name__ == "__main__":
    main()
