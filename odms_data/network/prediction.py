"""A network's depth predictions for the examples of a store, and a trained run's network.

The network sees each example's inputs as the loaders make them (models.py: ODN's n_obs evenly
spaced masks at the paper's 112x112, DBox's boxes and movements) and its output becomes a depth
as in training's validation.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import torch

from ..errors import InputError
from ..evaluation.predictions import write_predictions
from ..outputs import check_replaceable
from ..protocol import split_order
from ..store.build import Progress
from .models import Model, model_of
from .run_folder import BEST, LAST, PER_SET, RunFolder, TrainConfig
from .runtime import eval_batches, pick_device, read_checkpoint, to_device


def load_trained(
    folder: RunFolder, which: str, device: torch.device, split: str = ""
) -> tuple[torch.nn.Module, TrainConfig, int]:
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
    model = model_of(config).build().to(device)
    try:
        model.load_state_dict(saved.model)
    except (KeyError, RuntimeError):
        raise InputError(f"{path}: its weights do not fit the run's network ({config.model}, "
                         f"n_obs {config.n_obs}, radial {config.radial}); was config.json edited?") from None
    return model.eval(), config, saved.iteration


@torch.inference_mode()
def predict_store(
    net: torch.nn.Module, model: Model, path: str, device: torch.device, workers: int,
    progress: Progress = lambda split, done, total: None,
) -> tuple[str, list[str], np.ndarray]:
    """(split, example ids, predicted d1) of every example of the store at `path`;
    `progress(split, examples done, examples)` after each batch."""
    dataset = model.store_dataset(path)  # the store opened once, its batches read from it
    with dataset.examples.store as s:
        split, ids, n = s.attrs.split, s.example_ids, len(s)
        d1 = np.empty(n)
        done = 0
        for batch in eval_batches(dataset, workers, device.type == "cuda"):
            _, d = model.outputs_and_depths(net, to_device(batch, device))
            d1[batch["index"].numpy()] = d.cpu().numpy()
            done += len(batch["index"])
            progress(split, done, n)
    return split, ids, d1


Loaded = tuple[torch.nn.Module, TrainConfig, int]  # a network in eval mode, its config, its iteration


def predict(
    folder: RunFolder, stores: dict[str, Path | str], output: str | Path, *, which: str = "best",
    workers: int = 0, device: str | None = None, overwrite: bool = False,
    progress: Progress = lambda split, done, total: None,
) -> tuple[int, TrainConfig, dict[str, int]]:
    """Write the predictions file (schemas/PREDICTIONS.md) of the run's `which` checkpoint for every
    example of `stores` ({split: path}); returns (rows, the run's config, {split: the iteration of
    the checkpoint that predicted it})."""
    check_replaceable(output, overwrite, option="output", suffixes=(".csv",))  # now, and when written
    dev = pick_device(device)
    order = sorted(stores, key=split_order)
    # every checkpoint is loaded before the work, so that a missing one shows at once
    if which == PER_SET:
        loaded = {split: load_trained(folder, which, dev, split) for split in order}
    else:
        one = load_trained(folder, which, dev)
        loaded = dict.fromkeys(order, one)
    return _predict(loaded, stores, output, workers, dev, overwrite, progress)


def predict_from_weights(
    weights: str | Path, model: str, stores: dict[str, Path | str], output: str | Path, *, n_obs: int = 10,
    workers: int = 0, device: str | None = None, overwrite: bool = False,
    progress: Progress = lambda split, done, total: None,
) -> tuple[int, TrainConfig, dict[str, int]]:
    """As predict, with the network `model` of n_obs observations holding the weights of the state
    dict file `weights` (ODMD's DBox_pretrained_paper.pt, or DBox.state_dict() saved); its
    iteration is reported as 0."""
    check_replaceable(output, overwrite, option="-o", suffixes=(".csv",))
    dev = pick_device(device)
    loaded = dict.fromkeys(sorted(stores, key=split_order), load_weights(weights, model, n_obs, dev))
    return _predict(loaded, stores, output, workers, dev, overwrite, progress)


def load_weights(weights: str | Path, model: str, n_obs: int, device: torch.device) -> Loaded:
    """The network `model` of n_obs observations holding the state dict file `weights`, in eval mode,
    its config, and 0 for its iteration."""
    config = TrainConfig.recipe(model, n_obs=n_obs)
    return model_of(config).load_file(weights).to(device).eval(), config, 0


def _predict(
    loaded: dict[str, Loaded], stores: dict[str, Path | str], output: str | Path, workers: int,
    dev: torch.device, overwrite: bool, progress: Progress,
) -> tuple[int, TrainConfig, dict[str, int]]:
    """Predict each store `split` with the network `loaded[split]`, write the file."""
    rows: list[tuple[str, str, float]] = []
    iterations = {}
    for split, (net, config, iteration) in loaded.items():
        got, ids, d1 = predict_store(net, model_of(config), str(stores[split]), dev, workers, progress)
        rows += zip([got] * len(ids), ids, d1.tolist(), strict=True)
        iterations[split] = iteration
    write_predictions(output, rows, overwrite=overwrite)
    return len(rows), next(iter(loaded.values()))[1], iterations
