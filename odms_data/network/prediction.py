"""A network's depth predictions for the examples of a store, and a trained run's network.

The network sees each example's inputs as the loaders make them (odn.transform: n_obs evenly
spaced observations, the paper's 112x112 masks) and its output becomes a depth with
loaders.targets.depth, exactly as in training's validation.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np
import torch

from ..errors import InputError
from ..evaluation.predictions import write_predictions
from ..outputs import check_replaceable
from ..protocol import split_order
from . import odn
from .odn import ODN
from .run_folder import BEST, LAST, PER_SET, RunFolder, TrainConfig
from .runtime import eval_batches, outputs_and_depths, pick_device, read_checkpoint, store_dataset, to_device
from .variants import variant


def load_trained(
    folder: RunFolder, which: str, device: torch.device, split: str = ""
) -> tuple[ODN, TrainConfig, int]:
    """The network of a run's `which` checkpoint ('best', 'last', or 'per-set': the best on the
    validation set of `split`'s domain) in eval mode, its config and the iteration it was saved at."""
    config = folder.config()
    if which == PER_SET:
        path = folder.per_set_checkpoint(split)
    else:
        path = folder.file({"best": BEST, "last": LAST}[which])
    if not path.is_file():
        raise InputError(f"{folder.path}: has no {which} checkpoint yet ({path.name}); train it first "
                         "(a run writes one at each validation)")
    saved = read_checkpoint(path)
    model = odn.build(variant(config.model), config.n_obs, config.radial).to(device)
    try:
        model.load_state_dict(saved.model)
    except (KeyError, RuntimeError):
        raise InputError(f"{path}: its weights do not fit the run's network ({config.model}, "
                         f"n_obs {config.n_obs}, radial {config.radial}); was config.json edited?") from None
    return model.eval(), config, saved.iteration


@torch.inference_mode()
def predict_store(
    model: torch.nn.Module, config: TrainConfig, path: str, device: torch.device, workers: int,
    progress: Callable[[str, int, int], None] = lambda split, done, total: None,
) -> tuple[str, list[str], np.ndarray]:
    """(split, example ids, predicted d1) of every example of the store at `path`;
    `progress(split, examples done, examples)` after each batch."""
    dataset = store_dataset(path, config)  # the store opened once, its batches read from it
    with dataset.examples.store as s:
        split, ids, n = s.attrs.split, s.example_ids, len(s)
        v = variant(config.model)
        d1 = np.empty(n)
        done = 0
        for batch in eval_batches(dataset, workers, device.type == "cuda"):
            _, d = outputs_and_depths(model, v, to_device(batch, device))
            d1[batch["index"].numpy()] = d.cpu().numpy()
            done += len(batch["index"])
            progress(split, done, n)
    return split, ids, d1


def predict(
    folder: RunFolder, stores: dict[str, Path], output: str | Path, *, which: str = "best", workers: int = 0,
    device: str | None = None, overwrite: bool = False,
    progress: Callable[[str, int, int], None] = lambda split, done, total: None,
) -> tuple[int, TrainConfig, dict[str, int]]:
    """Write the predictions file (schemas/PREDICTIONS.md) of the run's `which` checkpoint for every
    example of `stores` ({split: path}); returns (rows, the run's config, {split: the iteration of
    the checkpoint that predicted it})."""
    check_replaceable(output, overwrite, option="output", suffixes=(".csv",))  # now, and when written
    dev = pick_device(device)
    order = sorted(stores, key=split_order)
    # every checkpoint is loaded before the work, so that a missing one shows at once
    loaded = {split: load_trained(folder, which, dev, split) for split in order} if which == PER_SET else {}
    model, config, iteration = loaded[order[0]] if loaded else load_trained(folder, which, dev)
    rows: list[tuple[str, str, float]] = []
    iterations = {}
    for split in order:
        if loaded:
            model, config, iteration = loaded[split]
        got, ids, d1 = predict_store(model, config, str(stores[split]), dev, workers, progress)
        rows += zip([got] * len(ids), ids, d1.tolist(), strict=True)
        iterations[split] = iteration
    write_predictions(output, rows, overwrite=overwrite)
    return len(rows), config, iterations
