"""Examples/s of the loaders: the streaming generator at 112x112 and 480x640 (n = 10) in-process
and with 1 and 2 worker processes, and a store read through each loader.

    python benchmarks/stream.py [--store sim-val.zarr] [--examples 4096] [--batch-size 256]

"112x112 coverage" streams the paper's inputs: masks equal to a store's shrunk to 112x112 with
INTER_AREA, as float32 covered fractions (the default transform); "uint8" the same fractions
rounded (Transform(rounded=True)); "direct" draws uint8 masks straight at 112x112
(GeneratedExamples(direct=True)). The baseline, measured in the same run, is
the naive streaming path: draw each mask at 480x640 with render.reference_masks and shrink it to
112x112. Timing starts once the batches asked for before the first one arrived have come too
(1 + 2 x the workers or threads, the most any loader here has under way at the start): every
worker has then started. A spawned worker loaded its kernels, about half a CPU-second each, which,
counted, put the 2-worker rows of an 8,192-example run at about 60 % of their steady rate.
Batches under way when timing starts are counted without the CPU spent on them before: parallel
rows read high by at most those batches over the batches of the run. grain reads with `threads`
threads and a prefetch buffer of as many batches, in-process or in mp_prefetch workers.

CPU-seconds are those of the whole process tree (this process and its worker processes, read
with psutil while they run, each with the children it has reaped), over the same span as the
wall time: the steady rate that says how many cores feed an accelerator. The warm-up column is
the CPU-seconds spent before timing starts (starting the workers, and the first batches).
"""

from __future__ import annotations

import argparse
import importlib.util
import os
import sys
import tempfile
import time
from collections.abc import Iterable
from pathlib import Path

import psutil

from odms_data.loaders import Transform, store_batches, stream_batches
from odms_data.loaders.sources import collate
from odms_data.simulate.generate_store import generate
from odms_data.simulate.object_model import sample_example
from odms_data.simulate.params import GeneratorParams
from odms_data.simulate.render import reference_masks

sys.path.insert(0, str(Path(__file__).resolve().parent))
import _results  # noqa: E402

PARAMS = GeneratorParams(n_obs=10)


def cpu_seconds() -> float:
    """CPU time of this process and its running descendants, each with that of the children it
    has reaped (workers forked by multiprocessing's fork server are its children, not ours)."""
    total = 0.0
    me = psutil.Process()
    for process in (me, *me.children(recursive=True)):
        try:
            total += sum(process.cpu_times()[:4])  # user, system, and those of its reaped children
        except psutil.NoSuchProcess:
            continue
    return total


def rate(batches: Iterable, batch_size: int, parallel: int = 0) -> tuple[float, float, float]:
    """Examples per wall second and per CPU-second once the first 1 + 2 * `parallel` batches
    (`parallel`: worker processes or threads) have arrived, and the CPU-seconds spent until then."""
    c0 = cpu_seconds()
    it = iter(batches)
    for _ in range(1 + 2 * parallel):
        next(it)
    count = 0
    c1, t0 = cpu_seconds(), time.perf_counter()
    for _ in it:
        count += batch_size
    wall, cpu = time.perf_counter() - t0, cpu_seconds() - c1
    del it  # ends the workers
    return count / wall, count / cpu, c1 - c0


def naive(batch_size: int, n_batches: int):
    """Full-size masks shrunk to 112x112: the path streaming at training size avoids."""
    t = Transform()
    for b in range(n_batches):
        out = []
        for i in range(b * batch_size, (b + 1) * batch_size):
            spec = sample_example(PARAMS, 0, i)
            out.append(t(reference_masks(spec, PARAMS), spec.z, spec.z[0]))
        yield collate(out)


def grain_stream(batch_size: int, n_batches: int, threads: int, workers: int):
    """The stream through grain: `threads` drawing batches (a small prefetch buffer), in
    `workers` mp_prefetch processes or in this one."""
    import grain

    from odms_data.loaders.grain_loader import stream_dataset

    options = grain.ReadOptions(num_threads=threads, prefetch_buffer_size=threads)
    ds = stream_dataset(batch_size, n_batches, params=PARAMS).to_iter_dataset(options)
    return ds.mp_prefetch(grain.MultiprocessingOptions(num_workers=workers)) if workers else ds


def grain_store(store: str, batch_size: int, workers: int):
    import grain

    from odms_data.loaders.grain_loader import StoreSource

    ds = grain.MapDataset.source(StoreSource(store)).batch(batch_size).to_iter_dataset()
    return ds.mp_prefetch(grain.MultiprocessingOptions(num_workers=workers))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--store", help="store to read (default: 4,096 generated examples in a temp dir)")
    ap.add_argument("--examples", type=int, default=4096, help="examples per streaming measurement")
    ap.add_argument("--batch-size", type=int, default=256)
    _results.add_options(ap)
    args = ap.parse_args()
    print(f"{len(os.sched_getaffinity(0))} CPUs available, batch size {args.batch_size}, n = {PARAMS.n_obs}")
    B = args.batch_size
    nb = max(8, args.examples // B)  # batches left once the warm-up batches are in
    results: list[tuple[str, float, float, float]] = []
    print(f"{'':<48} {'examples/s':>10} {'vs baseline':>11} {'examples/CPU-s':>15} {'vs baseline':>11} "
          f"{'warm-up CPU-s':>14}")

    def record(name: str, value: tuple[float, float, float]) -> None:
        results.append((name, *value))
        _, base, base_cpu, _ = results[0]
        wall, cpu, start = value
        line = f"{name:<48} {wall:10.0f} {wall / base:10.1f}x {cpu:15.0f} {cpu / base_cpu:10.1f}x"
        print(f"{line} {start:14.2f}", flush=True)

    record("baseline: 480x640 drawn, shrunk to 112x112", rate(naive(B, max(2, nb // 4)), B))
    for size, direct, rounded, label in (((112, 112), False, False, "112x112 coverage"),
                                         ((112, 112), False, True, "112x112 uint8"),
                                         ((112, 112), True, True, "112x112 direct uint8"),
                                         (None, False, True, "480x640 uint8")):
        t = Transform(size=size, rounded=rounded)
        b = B if size else 16  # a batch of 480x640 masks is 3 MB an example
        for workers in (0, 2):
            batches = stream_batches(b, max(8, nb * B // b // (1 if size else 4)), params=PARAMS, transform=t,
                                     direct=direct, workers=workers)
            record(f"numpy stream {label}, workers={workers}", rate(batches, b, workers))
    has_torch = importlib.util.find_spec("torch") is not None
    has_tf = importlib.util.find_spec("tensorflow") is not None
    has_grain = importlib.util.find_spec("grain") is not None
    if has_grain:
        for threads, workers in ((1, 0), (2, 0), (1, 2)):
            record(f"grain stream 112x112 coverage, threads={threads}, workers={workers}",
                   rate(grain_stream(B, nb, threads, workers), B, max(threads, workers)))
    if has_torch:
        from torch.utils.data import DataLoader

        from odms_data.loaders.torch_loader import StoreDataset, StreamDataset

        for rounded in (False, True):
            ds = StreamDataset(B, nb, params=PARAMS, transform=Transform(rounded=rounded))
            record(f"torch stream 112x112 {'uint8' if rounded else 'coverage'}, workers=2",
                   rate(DataLoader(ds, batch_size=None, num_workers=2), B, 2))
    if has_tf:
        from odms_data.loaders.tf_loader import from_generator

        record("tf stream 112x112 coverage, workers=2",
               rate(from_generator(B, nb, params=PARAMS, workers=2), B, 2))

    with tempfile.TemporaryDirectory() as tmp:
        store = args.store
        if store is None:
            store = str(Path(tmp) / "bench.zarr")
            generate(store, 4096, PARAMS, seed=1, workers=2)
        for workers in (0, 2):
            record(f"numpy store -> 112x112 coverage, workers={workers}",
                   rate(store_batches(store, B, workers=workers), B, workers))
        if has_torch:
            for workers in (0, 2):
                record(f"torch store -> 112x112 coverage, workers={workers}",
                       rate(DataLoader(StoreDataset(store), batch_size=B, num_workers=workers), B, workers))
        if has_grain:
            record("grain store -> 112x112 coverage, workers=2", rate(grain_store(store, B, 2), B, 2))
        if has_tf:
            from odms_data.loaders.tf_loader import from_store

            record("tf store -> 112x112 coverage, workers=2", rate(from_store(store, B, workers=2), B, 2))
    _, base, base_cpu, _ = results[0]
    rows = [{"loader": name, "examples/s": wall, "x baseline": wall / base, "examples/CPU-s": cpu,
             "x baseline (CPU)": cpu / base_cpu, "warm-up CPU-s": start}
            for name, wall, cpu, start in results[1:]]
    _results.save(args, "Loaders: examples/s of the streaming generator and of store reads",
                  {"what": "480x640 masks drawn and shrunk to 112x112, one process", "value": base_cpu,
                   "unit": "examples/CPU-s"}, rows,
                  {"batch_size": B, "n_obs": PARAMS.n_obs, "examples_per_row": nb * B})


if __name__ == "__main__":
    main()
