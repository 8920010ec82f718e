"""Box examples against mask examples: generation and streaming rates, measured in one run.

Run by hand: `python benchmarks/box_rates.py [--counts 512,10000,100000] [--batch 256] [--odmd DIR]`.
Times, as the median of --repeat runs, in examples per second on one process:

- `generate`: drawing each of --counts box examples (simulate.box_examples, preset odmd) and
  --mask-count mask examples (object_model and batch_render at the store's full size);
- with --odmd DIR, a checkout of griffbr/ODMD the user has (nothing is downloaded or copied): its
  released generator (standard_data.yaml, HSR camera, perturbations) making each count in one
  call, as its training demo does a batch, taking turns with ours in one process (`over_authors`);
- `stream`: loaders.stream_batches, batches of --batch of the network inputs (DBox's for boxes,
  ODN's 112x112 masks for masks), in process.

Writes benchmarks/results/box_rates.json (_results.py), the mask examples' generation rate as the
baseline.
"""

from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
import time
from pathlib import Path

from odms_data.loaders import stream_batches
from odms_data.simulate.batch_render import render_masks
from odms_data.simulate.box_examples import BOX_PRESETS
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


def generator_rates(repo: str | None, counts: list[int], repeat: int) -> dict[tuple[str, int], float]:
    """Examples/s of simulate.box_examples (preset odmd) and, with `repo`, of the authors' generator
    (standard_data.yaml, HSR camera, perturbations) making each count of examples in one call, as
    their training demo makes a batch. Both run in one child process, taking turns for every
    count and repetition (their modules import IPython, which it stubs when absent); the median."""
    child = f"""
import json, sys, time, types, statistics
import numpy as np
from odms_data.simulate.box_examples import BOX_PRESETS, sample_box_examples
repo, counts, repeat = {repo!r}, {counts!r}, {repeat}
runs = {{"ours": lambda n: sample_box_examples(BOX_PRESETS["odmd"], 0, np.arange(n))}}
if repo:
    sys.modules.setdefault("IPython", types.SimpleNamespace(embed=lambda: None))
    sys.path.insert(0, repo)
    import odmd
    g = odmd.data_gen.DataGenerator(repo + "/config/data_gen/standard_data.yaml")
    g.initialize_data_gen(repo + "/config/camera/hsr_grasp_camera.yaml")
    def theirs(n):
        b3, bb = g.generate_object_examples(n)
        odmd.data_gen.add_perturbations(b3, bb, g)
    runs["odmd"] = theirs
times = {{(k, n): [] for k in runs for n in counts}}
for _ in range(repeat + 1):  # the first round warms up
    for n in counts:
        for k, run in runs.items():
            t = time.perf_counter()
            run(n)
            times[k, n].append(time.perf_counter() - t)
print(json.dumps([[k, n, n / statistics.median(ts[1:])] for (k, n), ts in times.items()]))
"""
    out = subprocess.run([sys.executable, "-c", child], capture_output=True, text=True, check=True)
    return {(k, n): rate for k, n, rate in json.loads(out.stdout.splitlines()[-1])}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--counts", default="512,10000,100000",
                    help="box examples generated per timing, comma-separated (each timed in turn)")
    ap.add_argument("--mask-count", type=int, default=100, help="mask examples generated per timing")
    ap.add_argument("--batch", type=int, default=256)
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--odmd", help="a checkout of griffbr/ODMD, to time the authors' generator too")
    _results.add_options(ap)
    a = ap.parse_args()
    counts = [int(c) for c in a.counts.split(",")]
    boxes, masks = BOX_PRESETS["odmd"], PRESETS["standard"]
    streamed = a.batch * max(1, counts[0] // a.batch)
    generated = generator_rates(a.odmd, counts, a.repeat)
    masks_rate = median_rate(lambda: render_masks(sample_examples(masks, 0, range(a.mask_count)), masks),
                             a.mask_count, a.repeat)
    stream_rates = {
        "boxes (DBox inputs)": (streamed, median_rate(
            lambda: list(stream_batches(a.batch, max(1, counts[0] // a.batch), params=boxes)), streamed,
            a.repeat)),
        "masks (ODN's 112x112 inputs)": (a.mask_count, median_rate(
            lambda: list(stream_batches(a.mask_count, 1, params=masks)), a.mask_count, a.repeat)),
    }
    names = {"ours": "boxes (simulate.box_examples)", "odmd": "boxes (the authors' ODMD generator)"}
    rows = [{"what": "generate", "examples": "masks (object_model + batch_render)", "count": a.mask_count,
             "examples_per_s": masks_rate, "over_masks": 1.0, "over_authors": None}]
    for (k, n), rate in sorted(generated.items(), key=lambda kv: (kv[0][1], kv[0][0] != "ours")):
        theirs = generated.get(("odmd", n))
        rows.append({"what": "generate", "examples": names[k], "count": n, "examples_per_s": rate,
                     "over_masks": rate / masks_rate, "over_authors": rate / theirs if theirs else None})
    stream_masks = stream_rates["masks (ODN's 112x112 inputs)"][1]
    rows += [{"what": "stream", "examples": name, "count": count, "examples_per_s": rate,
              "over_masks": rate / stream_masks, "over_authors": None}
             for name, (count, rate) in stream_rates.items()]
    for row in rows:
        print(row)
    _results.save(a, "Box examples against mask examples and the authors' generator: generation and "
                     "streaming rates",
                  {"what": "generating mask examples", "value": masks_rate, "unit": "examples/s"},
                  rows, {"batch": a.batch, "repeat": a.repeat})


if __name__ == "__main__":
    main()
