"""The direct shard path (store/backends/zarr.py, sink.py) against zarr's own.

Run by hand: `python benchmarks/shards.py [--frames 4096] [--repeat 5]`. One local Zarr store of
generated-looking packed masks (480x640, 10 frames a chunk, 100 a shard) is written shard by shard
through a `MaskSink` and through `zarr` (`masks[a:b] = ...`), then read back one example (10
frames) at a time through `ShardReader` and through zarr. Both paths must give the same bytes.
Medians of --repeat runs, CPU seconds of this process; written to benchmarks/results/shards.json
(_results.py), zarr's own write as the baseline.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import zarr

from odms_data.store.backends import ShardReader
from odms_data.store.masks import packed_width
from odms_data.store.writer import Layout, StoreWriter

sys.path.insert(0, str(Path(__file__).resolve().parent))
import _results  # noqa: E402

H, W, CHUNK, SHARD = 480, 640, 10, 100


def masks(frames: int) -> np.ndarray:
    """Packed frames of one filled disc each, at varying places: compressible as masks are."""
    yy, xx = np.mgrid[:H, :W]
    out = np.empty((frames, H, packed_width(W)), np.uint8)
    for f in range(frames):
        cy, cx, r = 120 + f % 240, 160 + (7 * f) % 320, 40 + f % 60
        out[f] = np.packbits((yy - cy) ** 2 + (xx - cx) ** 2 < r * r, axis=-1)
    return out


def cpu(fn) -> float:
    start = time.process_time()
    fn()
    return time.process_time() - start


def run(folder: Path, packed: np.ndarray, direct: bool) -> tuple[float, float, np.ndarray]:
    """CPU seconds to write every shard and to read every example back, and what was read."""
    frames = len(packed)
    layout = Layout(height=H, width=W, n_frames=frames, n_examples=1, max_obs=1, id_width=1,
                    source_width=1, frames_per_chunk=CHUNK, frames_per_shard=SHARD, examples_per_chunk=1)
    with StoreWriter(str(folder / ("direct.zarr" if direct else "zarr.zarr")), overwrite=True) as w:
        w.create(layout)
        if direct:
            sink = w.mask_sink()
            shards = range(0, frames, SHARD)
            write = cpu(lambda: [sink.write_packed(s, packed[s : s + SHARD]) for s in shards])
        else:
            arr = w.arrays["masks"]
            write = cpu(lambda: [arr.__setitem__(slice(s, s + SHARD), packed[s : s + SHARD])
                                 for s in range(0, frames, SHARD)])
        path = w.partial
        back = np.empty_like(packed)
        if direct:
            opened = ShardReader.open(path)
            if opened is None:
                raise SystemExit("the direct reader does not recognise the layout StoreWriter makes")
            reader = opened

            def read() -> None:
                for s in range(0, frames, CHUNK):
                    back[s : s + CHUNK] = reader.read(s, s + CHUNK)
        else:
            masks_array = zarr.open_array(path, path="masks", mode="r")

            def read() -> None:
                for s in range(0, frames, CHUNK):
                    back[s : s + CHUNK] = masks_array[s : s + CHUNK]
        return write, cpu(read), back


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=4096)
    ap.add_argument("--repeat", type=int, default=5)
    _results.add_options(ap)
    a = ap.parse_args()
    packed = masks(a.frames)
    names = ("direct write", "zarr write", "direct read", "zarr read")
    times: dict[str, list[float]] = {k: [] for k in names}
    with tempfile.TemporaryDirectory() as tmp:
        for _ in range(a.repeat):
            for direct in (True, False):
                write, read, back = run(Path(tmp), packed, direct)
                if not np.array_equal(back, packed):
                    raise SystemExit(f"the {'direct' if direct else 'zarr'} path read back other bytes")
                name = "direct" if direct else "zarr"
                times[f"{name} write"].append(write)
                times[f"{name} read"].append(read)
    medians = {k: statistics.median(v) for k, v in times.items()}
    for k, v in medians.items():
        print(f"{k:13} {v:8.3f} CPU-s")
    rows = [{"operation": op, "direct_cpu_s": medians[f"direct {op}"], "zarr_cpu_s": medians[f"zarr {op}"],
             "zarr_over_direct": medians[f"zarr {op}"] / medians[f"direct {op}"]} for op in ("write", "read")]
    _results.save(a, f"Shards: the direct shard path against zarr's, {a.frames} packed 480x640 masks",
                  {"what": "zarr writing every shard (masks[a:b] = ...)", "value": medians["zarr write"],
                   "unit": "CPU-s"}, rows,
                  {"frames": a.frames, "image": [H, W], "frames_per_chunk": CHUNK, "frames_per_shard": SHARD,
                   "repeat": a.repeat})


if __name__ == "__main__":
    main()
