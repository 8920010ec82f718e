"""Imported by the fork server that worker pools fork their workers from (parallel.worker_pool):
the renderer's imports and compiled kernels, loaded there once, so that every worker starts warm.

A spawned worker would import the renderer and load its kernels itself before its first task; a
forked one inherits them. Importing this module runs each kernel
once, on the paths the generator and the loaders take: one example generated (not written) and
one drawn at training size as coverage and as 0/1 masks. OpenCV is held to one thread first:
the fork server is odms-data's own process, and a child forked from a process whose OpenCV had
started its thread pool hangs when it sets its own thread count.
"""

from __future__ import annotations

from ..parallel import one_opencv_thread
from ..store.backends import MaskSink
from .batch_render import render_masks, render_shrunk
from .object_model import sample_examples
from .params import PRESETS
from .shard_task import ShardTask
from .shards import run_shard

TRAINING_SIZE = (112, 112)


def warm() -> None:
    """Run each kernel once (Numba loads a kernel's machine code on its first call)."""
    params = PRESETS["perturb"]
    unwritten = MaskSink("", "hdf5", params.n_obs)  # HDF5: the chunks come back, unwritten
    run_shard(ShardTask(unwritten, params, 0, "warm", 1, 0, 1))
    specs = sample_examples(params, 0, range(1))
    render_shrunk(specs, params, TRAINING_SIZE, None, True)
    render_shrunk(specs, params, TRAINING_SIZE, None, False)
    render_masks(specs, params, TRAINING_SIZE)


one_opencv_thread()
warm()
