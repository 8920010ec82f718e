"""The paper's training recipe for ODN, on the endless stream of generated examples.

As the paper (section 4) and the authors' released demo train it: Adam with learning rate 1e-3,
batches of 512 freshly generated examples, an L1 loss between the output and the variant's label
(loaders/targets.py), 5,000 iterations. Every `val_every` iterations (the paper: 10) and at the
last, the network is evaluated on the validation stores; `best.pt` keeps the weights whose mean
of the stores' mean percent errors is lowest, `last.pt` what a resumed run needs (weights, Adam's
state, the random state, the iteration). The stream's batch b depends only on (preset, seed,
n_obs, batch size, b), so a run resumed from last.pt sees exactly the batches it would have seen.
"""

from __future__ import annotations

import io
import time
from collections.abc import Callable
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
import torch
from torch.utils.data import DataLoader

from ..errors import InputError
from ..evaluation.metrics import percent_errors
from ..loaders.torch_loader import StreamDataset
from ..outputs import output_lock, replaced_via_partial
from ..simulate.params import PRESETS, GeneratorParams
from ..store.reader import open_store
from . import odn
from .odn import ODN
from .prediction import (
    CHECKPOINT,
    Batch,
    outputs_and_depths,
    pick_device,
    read_checkpoint,
    store_batches,
    to_device,
)
from .run_folder import BEST, LAST, RUN_KIND, TRAIN, VAL, AddRow, RunFolder, TrainConfig
from .variants import Variant, variant


@dataclass
class Status:
    """Where a run stands, reported after every iteration."""

    iteration: int
    iterations: int
    batch_size: int
    started_at: int  # the iteration this session started from (0, or where it resumed)
    seconds: float  # this session's wall time
    device: str = "cpu"
    loss: float = float("nan")  # the last training batch's L1 loss
    train_error: float = float("nan")  # and its mean percent error
    val: float | None = None  # the last validation's mean percent error
    best: float | None = None
    best_iteration: int | None = None
    checkpoint: int = 0  # the iteration of last.pt, where a rerun resumes

    @property
    def iterations_per_s(self) -> float:
        return (self.iteration - self.started_at) / self.seconds if self.seconds > 0 else 0.0

    @property
    def examples_per_s(self) -> float:
        return self.iterations_per_s * self.batch_size


def stream_params(config: TrainConfig) -> GeneratorParams:
    """The generator's parameters for the stream: the preset's (10 observations, of which the
    network sees n_obs evenly spaced ones, as the authors' demo does), more when n_obs asks."""
    params = PRESETS[config.preset]
    return params if config.n_obs <= params.n_obs else replace(params, n_obs=config.n_obs)


class Validation:
    """The validation stores' network inputs, read once and kept on the device (about 0.5 MB an
    example at n = 10); calling it evaluates a network on them."""

    def __init__(self, config: TrainConfig, device: torch.device, workers: int) -> None:
        self.variant = variant(config.model)
        keep = ["masks", "radial", self.variant.distances, self.variant.label, "dz", "d1"]
        self.stores: dict[str, list[Batch]] = {}
        for path in config.val:
            with open_store(path) as s:
                split, labelled = s.attrs.split, int(np.isfinite(s.d1).sum())
            if split in self.stores or split in (TRAIN, VAL):
                raise InputError(f"{path}: a validation store of split '{split}' again or of a name the "
                                 "curves use (train, val); give each split once, none named train or val")
            if not labelled:
                raise InputError(f"{path}: no labelled example (every d1 is NaN); it cannot validate")
            batches = store_batches(path, config, workers, pin=device.type == "cuda")
            self.stores[split] = [to_device({k: b[k] for k in keep if k in b}, device) for b in batches]

    @torch.inference_mode()
    def __call__(self, model: ODN) -> dict[str, tuple[float, float]]:
        """{split: (L1 loss, mean percent error)} over each store's labelled examples."""
        model.eval()
        out = {}
        for split, batches in self.stores.items():
            losses, errors = [], []
            for b in batches:
                output, d = outputs_and_depths(model, self.variant, b)
                labelled = torch.isfinite(b["d1"])
                losses.append((output - b[self.variant.label]).abs()[labelled].cpu().numpy())
                truth = b["d1"][labelled].double()
                errors.append(percent_errors(d[labelled].cpu().numpy(), truth.cpu().numpy()))
            out[split] = (float(np.concatenate(losses).mean()), float(np.concatenate(errors).mean()))
        model.train()
        return out


def _save(path: Path, content: dict) -> None:
    """Write a checkpoint: serialised in memory first, so that a full disk is an OSError (which
    outputs.py makes one line) and not torch's RuntimeError."""
    buffer = io.BytesIO()
    torch.save(content, buffer)
    with replaced_via_partial(path) as partial, open(partial, "xb") as f:
        f.write(buffer.getbuffer())


def train(
    path: str | Path,
    config: TrainConfig,
    *,
    workers: int = 0,
    device: str | None = None,
    overwrite: bool = False,
    report: Callable[[Status], None] = lambda s: None,
) -> Status:
    """Train (or resume) the run at `path`, under its lock; `workers` processes make the stream's
    batches. Returns the final status; a run that is already complete returns at once."""
    with output_lock(path, RUN_KIND):
        return _train(path, config, workers, device, overwrite, report)


def _train(path: str | Path, config: TrainConfig, workers: int, device: str | None, overwrite: bool,
           report: Callable[[Status], None]) -> Status:
    folder, v, dev = RunFolder(path), variant(config.model), pick_device(device)
    status = Status(0, config.iterations, config.batch_size, 0, 0.0, str(dev))
    saved = read_checkpoint(folder.file(LAST), tuple(CHECKPOINT)) if folder.check(config, overwrite) else {}
    if saved:
        status.iteration = status.started_at = status.checkpoint = int(saved["iteration"])
        status.best, status.best_iteration = saved["best"], saved["best_iteration"]
    if status.iteration >= config.iterations:
        return status
    validation = Validation(config, dev, workers)  # reads the stores: their problems show before any write
    folder.create(config, overwrite)
    torch.manual_seed(config.seed)
    model = odn.build(v, config.n_obs, config.radial).to(dev)
    optimizer = torch.optim.Adam(model.parameters(), lr=config.lr)
    spent = 0.0  # training seconds up to the checkpoint resumed from
    if saved:
        model.load_state_dict(saved["model"])
        optimizer.load_state_dict(saved["optimizer"])
        torch.set_rng_state(saved["rng"])
        if dev.type == "cuda" and "cuda_rng" in saved:
            torch.cuda.set_rng_state(saved["cuda_rng"], dev)
        spent = float(saved["seconds"])
    stream = StreamDataset(config.batch_size, config.iterations, params=stream_params(config),
                           seed=config.seed, transform=odn.transform(config.n_obs, config.radial),
                           start=status.iteration)
    # its own generator: a DataLoader draws a base seed, from the global one (dropout's) by default
    loader = DataLoader(stream, batch_size=None, num_workers=workers, pin_memory=dev.type == "cuda",
                        generator=torch.Generator().manual_seed(config.seed))
    model.train()
    start = time.perf_counter()
    with folder.curves(upto=status.iteration) as add:
        for it, batch in enumerate(loader, status.iteration + 1):
            _step(model, optimizer, v, to_device(batch, dev), status)
            status.iteration, status.seconds = it, time.perf_counter() - start
            add(it, spent + status.seconds, TRAIN, status.loss, status.train_error)
            if it % config.val_every == 0 or it == config.iterations:
                _validate(folder, model, optimizer, validation, status, add, spent + status.seconds, dev)
            report(status)
    return status


def _step(model: ODN, optimizer: torch.optim.Optimizer, v: Variant, batch: Batch, status: Status) -> None:
    output, d = outputs_and_depths(model, v, batch)
    loss = (output - batch[v.label]).abs().mean()
    optimizer.zero_grad(set_to_none=True)
    loss.backward()
    optimizer.step()
    status.loss = loss.item()
    status.train_error = float(percent_errors(d.cpu().numpy(), batch["d1"].double().cpu().numpy()).mean())


def _validate(folder: RunFolder, model: ODN, optimizer: torch.optim.Optimizer, validation: Validation,
              status: Status, add: AddRow, seconds: float, dev: torch.device) -> None:
    """Evaluate on the validation stores, log it, keep the best weights, checkpoint the run."""
    results = validation(model)
    for split, (loss, error) in results.items():
        add(status.iteration, seconds, split, loss, error)
    status.val = float(np.mean([e for _, e in results.values()]))
    add(status.iteration, seconds, VAL, float(np.mean([loss for loss, _ in results.values()])), status.val)
    if status.best is None or status.val < status.best:
        status.best, status.best_iteration = status.val, status.iteration
        _save(folder.file(BEST), {"iteration": status.iteration, "model": model.state_dict(),
                                  "percent_error": status.val})
    _save(folder.file(LAST), {
        "iteration": status.iteration, "seconds": seconds, "model": model.state_dict(),
        "optimizer": optimizer.state_dict(), "rng": torch.get_rng_state(),
        **({"cuda_rng": torch.cuda.get_rng_state(dev)} if dev.type == "cuda" else {}),
        "best": status.best, "best_iteration": status.best_iteration,
    })
    status.checkpoint = status.iteration
