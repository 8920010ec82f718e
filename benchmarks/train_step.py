"""ODN's training speed on this machine's CPU: the network's step alone, the stream alone, and both.

    python benchmarks/train_step.py --batch 64 --steps 5 --workers 2

Baseline: a training step (forward, L1 loss, backward, Adam) of ODN_l on a batch of random
inputs in PyTorch's default (contiguous) memory format. Against it, in the same run: the same
step with odms-data's channels-last layout (and the largest output difference between the two),
the PyTorch stream of generated batches alone, and `network.training.train` (stream + steps +
one validation on a small generated store) for the same number of steps. Rates in examples/s.
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from pathlib import Path

import torch
from torch.utils.data import DataLoader

from odms_data.loaders.torch_loader import StreamDataset
from odms_data.network import odn
from odms_data.network.run_folder import TrainConfig
from odms_data.network.training import train
from odms_data.network.variants import variant
from odms_data.simulate.generate_store import generate
from odms_data.simulate.params import PRESETS

sys.path.insert(0, str(Path(__file__).resolve().parent))
import _results  # noqa: E402


def step_rate(model: torch.nn.Module, images: torch.Tensor, zbar: torch.Tensor, label: torch.Tensor,
              steps: int) -> float:
    opt = torch.optim.Adam(model.parameters(), lr=1e-3)

    def step() -> None:
        loss = (model(images, zbar) - label).abs().mean()
        opt.zero_grad()
        loss.backward()
        opt.step()

    step()  # the first builds the kernels
    start = time.perf_counter()
    for _ in range(steps):
        step()
    return steps * len(images) / (time.perf_counter() - start)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--batch", type=int, default=64)
    ap.add_argument("--steps", type=int, default=5)
    ap.add_argument("--workers", type=int, default=os.cpu_count() or 1)
    _results.add_options(ap)
    args = ap.parse_args()
    b, v = args.batch, variant("odn-l")
    torch.manual_seed(0)
    images, zbar, label = torch.rand(b, 10, 112, 112).round(), torch.rand(b, 8), torch.rand(b)

    contiguous = odn.ODN(10, v.n_distances(10))
    channels_last = odn.build(v, 10, radial=False)
    channels_last.load_state_dict(contiguous.state_dict())
    images_cl = images.contiguous(memory_format=torch.channels_last)
    with torch.no_grad():
        differ = (contiguous.eval()(images, zbar) - channels_last.eval()(images_cl, zbar)).abs().max().item()
    base = step_rate(contiguous.train(), images, zbar, label, args.steps)
    fast = step_rate(channels_last.train(), images_cl, zbar, label, args.steps)

    stream = DataLoader(StreamDataset(b, args.steps + 1, seed=1, transform=odn.transform(10, False)),
                        batch_size=None, num_workers=args.workers)
    it = iter(stream)
    next(it)  # workers started
    start = time.perf_counter()
    for _ in it:
        pass
    stream_rate = args.steps * b / (time.perf_counter() - start)

    with tempfile.TemporaryDirectory() as tmp:
        store = Path(tmp) / "val.zarr"
        generate(str(store), 64, PRESETS["standard"], seed=7, split="bench-val", workers=1)
        config = TrainConfig(iterations=args.steps, batch_size=b, val_every=args.steps, val=(str(store),))
        status = train(Path(tmp) / "run", config, workers=args.workers)
        train_rate = status.examples_per_s

    print(f"ODN_l steps of {b} examples, {args.steps} steps, torch threads {torch.get_num_threads()}, "
          f"stream workers {args.workers}")
    print("| | examples/s | vs baseline |\n| --- | ---: | ---: |")
    rows = []
    for name, rate in (("baseline: a step, contiguous memory format", base),
                       ("a step, channels-last (odms-data)", fast),
                       (f"the stream alone, {args.workers} workers", stream_rate),
                       ("train(): stream + steps + 1 validation of 64", train_rate)):
        print(f"| {name} | {rate:,.1f} | {rate / base:.2f}x |")
        rows.append({"what": name, "examples/s": rate, "x baseline": rate / base})
    print(f"largest output difference, channels-last vs contiguous: {differ:.2e}")
    _results.save(args, f"ODN's training speed on the CPU (batches of {b}, {args.steps} steps, "
                  f"{torch.get_num_threads()} torch threads)",
                  {"what": "a training step of ODN_l, contiguous memory format", "value": base,
                   "unit": "examples/s"}, rows[1:], {"largest_output_difference": differ})


if __name__ == "__main__":
    main()
