"""A network's depth predictions for the examples of a store, and a trained run's network.

The network sees each example's inputs as the loaders make them (odn.transform: n_obs evenly
spaced observations, the paper's 112x112 masks) and its output becomes a depth with
loaders.targets.depth, exactly as in training's validation.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import numpy as np
import torch
from torch.utils.data import DataLoader

from ..benchmark import split_order
from ..errors import InputError, OdmsError
from ..evaluation.predictions import write_predictions
from ..loaders.targets import depth
from ..loaders.torch_loader import StoreDataset
from ..outputs import check_replaceable
from ..store.reader import open_store
from . import odn
from .odn import ODN
from .run_folder import BEST, LAST, RunFolder, TrainConfig
from .variants import Variant, variant

EVAL_BATCH = 256  # examples a forward pass in evaluation
Batch = dict[str, torch.Tensor]  # a loader batch: network inputs and labels by name


def pick_device(name: str | None) -> torch.device:
    """The device called `name`, or the first GPU when there is one, else the CPU."""
    if name is None:
        return torch.device("cuda" if torch.cuda.is_available() else "cpu")
    try:
        device = torch.device(name)
    except RuntimeError:
        raise InputError(f"--device '{name}' is not a device name (cpu, cuda, cuda:1, ...)") from None
    if device.type == "cuda" and not torch.cuda.is_available():
        raise InputError(f"--device {name}: PyTorch sees no CUDA device on this machine")
    return device


def outputs_and_depths(model: torch.nn.Module, v: Variant, batch: Batch) -> tuple[torch.Tensor, torch.Tensor]:
    """The network's outputs for a batch (on the model's device) and the depths they mean (float64:
    d1 = s span / (1 - s) magnifies float32 rounding where the scale s is near 1)."""
    out = model(*odn.inputs(batch, v))
    return out, depth(v.label, out.detach().double(), batch["dz"][:, -1].double())


def to_device(batch: Batch, device: torch.device) -> Batch:
    return {k: t.to(device, non_blocking=True) for k, t in batch.items()}


WORKER_ERROR = "in DataLoader worker process"  # how torch says an exception came from a worker


def store_batches(path: str, config: TrainConfig, workers: int, pin: bool) -> Iterator[Batch]:
    """The store's examples as network inputs, in row order, EVAL_BATCH at a time. A problem a
    worker meets (a damaged chunk) is raised with its own one-line message: torch raises it again
    with the worker's traceback as its message."""
    dataset = StoreDataset(path, odn.transform(config.n_obs, config.radial))
    try:
        yield from DataLoader(dataset, batch_size=EVAL_BATCH, num_workers=workers, pin_memory=pin)
    except OdmsError as e:
        if WORKER_ERROR not in str(e):
            raise
        raise type(e)(str(e).rstrip().splitlines()[-1].split(": ", 1)[-1]) from None



# what a checkpoint holds (training.py writes it): key -> type
CHECKPOINT = {"model": dict, "iteration": int, "optimizer": dict, "rng": torch.Tensor,
              "best": float, "best_iteration": int, "seconds": float}
WEIGHTS = ("model", "iteration")  # what predicting needs; resuming needs all of CHECKPOINT


def read_checkpoint(path: Path, keys: tuple[str, ...] = WEIGHTS) -> dict[str, Any]:
    """A checkpoint's content, on the CPU (the random states must be there; load_state_dict moves
    weights and Adam's state to their module's device), with at least `keys`, checked."""
    try:
        saved = torch.load(path, map_location="cpu", weights_only=True)
    except Exception as e:  # a truncated or foreign file: torch raises many kinds
        raise InputError(f"{path}: not a readable checkpoint ({type(e).__name__}: {e})") from None
    problem = checkpoint_problem(saved, keys)
    if problem:
        raise InputError(f"{path}: not a checkpoint of odms-data ({problem})")
    return saved


def checkpoint_problem(saved: Any, keys: tuple[str, ...]) -> str | None:
    """What is wrong with the structure of a loaded checkpoint, or None."""
    if not isinstance(saved, dict):
        return f"it holds a {type(saved).__name__}, not a dict"
    for key in keys:
        want, value = CHECKPOINT[key], saved.get(key)
        if isinstance(value, bool) or not isinstance(value, int | float if want is float else want):
            return f"'{key}' is {type(value).__name__ if key in saved else 'missing'}, not {want.__name__}"
    weights = saved["model"]
    bad = [k for k, t in weights.items() if not isinstance(k, str) or not isinstance(t, torch.Tensor)]
    return f"its weight {bad[0]!r} is not a tensor" if bad else None


def load_trained(folder: RunFolder, which: str, device: torch.device) -> tuple[ODN, TrainConfig, int]:
    """The network of a run's `which` checkpoint ('best' or 'last') in eval mode, its config and
    the iteration it was saved at."""
    config = folder.config()
    path = folder.file({"best": BEST, "last": LAST}[which])
    if not path.is_file():
        raise InputError(f"{folder.path}: has no {which} checkpoint yet ({path.name}); train it first "
                         "(a run writes one at each validation)")
    saved = read_checkpoint(path)
    model = odn.build(variant(config.model), config.n_obs, config.radial).to(device)
    try:
        model.load_state_dict(saved["model"])
    except (KeyError, RuntimeError):
        raise InputError(f"{path}: its weights do not fit the run's network ({config.model}, "
                         f"n_obs {config.n_obs}, radial {config.radial}); was config.json edited?") from None
    return model.eval(), config, int(saved["iteration"])


@torch.inference_mode()
def predict_store(
    model: torch.nn.Module, config: TrainConfig, path: str, device: torch.device, workers: int,
    progress: Callable[[int], None] = lambda n: None,
) -> tuple[str, list[str], np.ndarray]:
    """(split, example ids, predicted d1) of every example of the store at `path`."""
    with open_store(path) as s:
        split, ids, n = s.attrs.split, s.example_ids, len(s)
    v = variant(config.model)
    d1 = np.empty(n)
    for batch in store_batches(path, config, workers, device.type == "cuda"):
        _, d = outputs_and_depths(model, v, to_device(batch, device))
        d1[batch["index"].numpy()] = d.cpu().numpy()
        progress(len(batch["index"]))
    return split, ids, d1


def predict(
    folder: RunFolder, stores: dict[str, Path], output: str | Path, *, which: str = "best", workers: int = 0,
    device: str | None = None, overwrite: bool = False, progress: Callable[[int], None] = lambda n: None,
) -> tuple[int, TrainConfig, int]:
    """Write the predictions file (schemas/PREDICTIONS.md) of the run's `which` checkpoint for every
    example of `stores` ({split: path}); returns (rows, the run's config, the checkpoint's iteration)."""
    check_replaceable(output, overwrite, option="-o", suffixes=(".csv",))  # before the work, and when written
    dev = pick_device(device)
    model, config, iteration = load_trained(folder, which, dev)
    rows: list[tuple[str, str, float]] = []
    for split in sorted(stores, key=split_order):
        got, ids, d1 = predict_store(model, config, str(stores[split]), dev, workers, progress)
        rows += zip([got] * len(ids), ids, d1.tolist(), strict=True)
    write_predictions(output, rows, overwrite=overwrite)
    return len(rows), config, iteration
