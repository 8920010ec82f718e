"""Examples/s of the PyTorch coverage renderer (simulate/torch_render.py) on a device, against the
CPU renderer (batch_render.render_shrunk, one process) measured in the same run.

    python benchmarks/torch_render.py [--device cuda] [--batch-size 512] [--batches 8]

n = 10 frames an example, 112x112 float32 coverage masks, the standard preset. The examples'
draws (object_model.sample_example) are made beforehand and not timed in either column, so the
rates compare drawing the masks; the device column also counts the polygons its CPU side
computes (batch_render.frame_geometry). The first device batch (warm-up) is not timed. Each device batch is
checked against the CPU renderer's masks (largest difference printed).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np
import torch

from odms_data.simulate.batch_render import render_shrunk
from odms_data.simulate.object_model import sample_example
from odms_data.simulate.params import GeneratorParams
from odms_data.simulate.torch_render import render_coverage

sys.path.insert(0, str(Path(__file__).resolve().parent))
import _results  # noqa: E402

PARAMS = GeneratorParams(n_obs=10)
SIZE = (112, 112)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--device", default="cuda" if torch.cuda.is_available() else "cpu")
    ap.add_argument("--batch-size", type=int, default=512)
    ap.add_argument("--batches", type=int, default=8)
    _results.add_options(ap)
    a = ap.parse_args()
    B = a.batch_size
    batches = [[sample_example(PARAMS, 0, b * B + i) for i in range(B)] for b in range(a.batches + 1)]
    t = time.perf_counter()
    cpu = [render_shrunk(specs, PARAMS, SIZE, coverage=True) for specs in batches[1:]]
    cpu_rate = B * a.batches / (time.perf_counter() - t)
    render_coverage(batches[0], PARAMS, SIZE, device=a.device)
    sync = torch.cuda.synchronize if a.device.startswith("cuda") else (lambda: None)
    sync()
    t = time.perf_counter()
    drawn = [render_coverage(specs, PARAMS, SIZE, device=a.device) for specs in batches[1:]]
    sync()
    rate = B * a.batches / (time.perf_counter() - t)
    worst = max(float(np.abs(d.cpu().numpy() - c).max()) for d, c in zip(drawn, cpu, strict=True))
    cuda = a.device.startswith("cuda")
    name = torch.cuda.get_device_name() if cuda else f"CPU, {torch.get_num_threads()} threads"
    print(f"device {a.device} ({name}), batch size {B}, {a.batches} batches, n = {PARAMS.n_obs}")
    print(f"CPU renderer (render_shrunk, one process): {cpu_rate:9.0f} examples/s")
    print(f"torch_render on {a.device}: {rate:23.0f} examples/s  {rate / cpu_rate:6.2f}x the CPU renderer")
    print(f"largest difference from the CPU renderer: {worst:.2e}")
    _results.save(a, "The PyTorch coverage renderer on a device against the CPU renderer",
                  {"what": "CPU renderer (render_shrunk, one process)", "value": cpu_rate,
                   "unit": "examples/s"},
                  [{"device": f"{a.device} ({name})", "batch size": B, "batches": a.batches,
                    "examples/s": rate, "x CPU renderer": rate / cpu_rate, "largest difference": worst}])


if __name__ == "__main__":
    main()
