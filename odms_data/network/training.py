"""The authors' training recipe for ODN and DBox, on the endless stream of generated examples.

As the papers and the authors' released demos train them: Adam with learning rate 1e-3, batches
of 512 freshly generated examples, an L1 loss between the output and the variant's label
(loaders/targets.py, loaders/box_transform.py); 5,000 iterations for ODN, 100,000 for DBox
(variants.py holds each recipe, models.py what differs between the networks). Every `val_every`
iterations (ODN's paper: 10) and at the last, the network is evaluated on the validation stores;
`best.pt` keeps the weights whose mean of the stores' mean percent errors is lowest,
`best-SPLIT.pt` those lowest on each store (the authors picked a checkpoint per set so),
`last.pt` what a resumed run needs (weights, Adam's state, the random state, the iteration).
The stream's batch b depends only on (preset, seed, n_obs, batch size, b), so a run resumed from
last.pt sees exactly the batches it would have seen.
"""

from __future__ import annotations

import io
import os
import shutil
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import torch
from torch.utils.data import DataLoader

from ..errors import InputError
from ..evaluation.metrics import percent_errors
from ..interrupts import stop_signal
from ..outputs import output_lock, replaced_via_partial
from ..urls import refuse_url
from .checkpoint import Checkpoint
from .models import Batch, Model, model_of
from .run_folder import BEST, LAST, RUN_OUTPUT, TRAIN, VAL, AddRow, RunFolder, TrainConfig, best_of
from .runtime import eval_batches, pick_device, read_checkpoint, to_device


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
    val_every: int = 1
    first_seconds: float = 0.0  # this session's first iteration, which includes the loader's start
    val_seconds: float = 0.0  # this session's time in validation (and checkpoints)
    validations: int = 0  # ... over this many
    best_per_set: dict[str, tuple[float, int]] = field(default_factory=dict)  # split: (error, iteration)

    @property
    def iterations_per_s(self) -> float:
        return (self.iteration - self.started_at) / self.seconds if self.seconds > 0 else 0.0

    @property
    def examples_per_s(self) -> float:
        return self.iterations_per_s * self.batch_size

    @property
    def seconds_left(self) -> float | None:
        """Wall time to the end: the iterations left at the rate of this session's after its first,
        and the validations left at their mean time; None until both were measured."""
        steps = self.iteration - self.started_at - 1
        if steps < 1 or not self.validations:
            return None
        per_step = max(0.0, self.seconds - self.first_seconds - self.val_seconds) / steps
        last = self.iterations % self.val_every != 0 and self.iteration < self.iterations  # validated too
        validations_left = self.iterations // self.val_every - self.iteration // self.val_every + last
        per_validation = self.val_seconds / self.validations
        return (self.iterations - self.iteration) * per_step + validations_left * per_validation


class Validation:
    """The validation stores' network inputs, read once and kept on the device (ODN's: about 0.5 MB
    an example at n = 10); calling it evaluates a network on them."""

    def __init__(self, model: Model, device: torch.device, workers: int) -> None:
        self.model = model
        keep = model.kept()
        self.stores: dict[str, list[Batch]] = {}
        for path in model.config.val:
            dataset = model.store_dataset(path)  # the store opened once, its batches read from it
            with dataset.examples.store as s:
                split, labelled = s.attrs.split, int(np.isfinite(s.d1).sum())
                if split in self.stores or split in (TRAIN, VAL):
                    raise InputError(f"{path}: a validation store of split '{split}' again or of a name the "
                                     "curves use (train, val); give each split once, none named train or val")
                if not labelled:
                    raise InputError(f"{path}: no labelled example (every d1 is NaN); it cannot validate")
                batches = eval_batches(dataset, workers, pin=device.type == "cuda")
                self.stores[split] = [to_device({k: b[k] for k in keep if k in b}, device) for b in batches]

    @torch.inference_mode()
    def __call__(self, net: torch.nn.Module) -> dict[str, tuple[float, float]]:
        """{split: (L1 loss, mean percent error)} over each store's labelled examples."""
        net.eval()
        out = {}
        label, truth = self.model.variant.label, self.model.truth
        for split, batches in self.stores.items():
            losses, errors = [], []
            for b in batches:
                output, d = self.model.outputs_and_depths(net, b)
                labelled = torch.isfinite(b[truth])
                losses.append((output - b[label]).abs()[labelled].cpu().numpy())
                known = b[truth][labelled].double()
                errors.append(percent_errors(d[labelled].cpu().numpy(), known.cpu().numpy()))
            out[split] = (float(np.concatenate(losses).mean()), float(np.concatenate(errors).mean()))
        net.train()
        return out


def _save(path: Path, checkpoint: Checkpoint) -> None:
    """Write a checkpoint: serialised in memory first, so that a full disk is an OSError (which
    outputs.py makes one line) and not torch's RuntimeError."""
    buffer = io.BytesIO()
    torch.save(checkpoint.to_json(), buffer)
    with replaced_via_partial(path, check=read_checkpoint) as partial, open(partial, "xb") as f:
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
    batches. Returns the final status; a run that is already complete returns at once. A run that
    fails (an error, not an interruption, which a rerun resumes) leaves no folder it made. PyTorch's
    global random state (seeded from the config) is the caller's again afterwards."""
    refuse_url(path, "a training run")
    with output_lock(path, RUN_OUTPUT), torch.random.fork_rng(range(torch.cuda.device_count())):
        made = not os.path.lexists(path)
        try:
            return _train(path, config, workers, device, overwrite, report)
        except Exception as e:
            if made and os.path.isdir(path) and not os.path.islink(path) and stop_signal(e) is None:
                shutil.rmtree(path, ignore_errors=True)
            raise


def _train(path: str | Path, config: TrainConfig, workers: int, device: str | None, overwrite: bool,
           report: Callable[[Status], None]) -> Status:
    if not config.val:
        raise InputError("training configuration: give at least one validation store")
    folder, m, dev = RunFolder(path), model_of(config), pick_device(device)
    status = Status(0, config.iterations, config.batch_size, 0, 0.0, str(dev), val_every=config.val_every)
    saved = read_checkpoint(folder.file(LAST)) if folder.check(config, overwrite) else None
    if saved:
        status.iteration = status.started_at = status.checkpoint = saved.iteration
        status.best, status.best_iteration = saved.best, saved.best_iteration
        status.best_per_set = dict(saved.best_per_set or {})
    if status.iteration >= config.iterations:
        return status
    validation = Validation(m, dev, workers)  # reads the stores: their problems show before any write
    folder.create(config, overwrite)
    torch.manual_seed(config.seed)
    net = m.build().to(dev)
    optimizer = torch.optim.Adam(net.parameters(), lr=config.lr)
    spent = 0.0  # training seconds up to the checkpoint resumed from
    if saved:
        adam, rng, spent = saved.resume_state(str(folder.file(LAST)))
        net.load_state_dict(saved.model)
        optimizer.load_state_dict(adam)
        torch.set_rng_state(rng)
        if dev.type == "cuda" and saved.cuda_rng is not None:
            torch.cuda.set_rng_state(saved.cuda_rng, dev)
    stream = m.stream(start=status.iteration)
    # its own generator: a DataLoader draws a base seed, from the global one (dropout's) by default
    loader = DataLoader(stream, batch_size=None, num_workers=workers, pin_memory=dev.type == "cuda",
                        generator=torch.Generator().manual_seed(config.seed))
    net.train()
    start = time.perf_counter()
    with folder.curves(upto=status.iteration) as add:
        for it, batch in enumerate(loader, status.iteration + 1):
            _step(m, net, optimizer, to_device(batch, dev), status)
            status.iteration, status.seconds = it, time.perf_counter() - start
            if it == status.started_at + 1:
                status.first_seconds = status.seconds
            add(it, spent + status.seconds, TRAIN, status.loss, status.train_error)
            if it % config.val_every == 0 or it == config.iterations:
                _validate(folder, net, optimizer, validation, status, add, spent + status.seconds, dev)
                validated = time.perf_counter() - start
                status.val_seconds += validated - status.seconds
                status.validations += 1
                status.seconds = validated
            report(status)
    return status


def _step(m: Model, net: torch.nn.Module, optimizer: torch.optim.Optimizer, batch: Batch,
          status: Status) -> None:
    output, d = m.outputs_and_depths(net, batch)
    loss = (output - batch[m.variant.label]).abs().mean()
    optimizer.zero_grad(set_to_none=True)
    loss.backward()
    optimizer.step()
    status.loss = loss.item()
    truth = batch[m.truth].double().cpu().numpy()
    status.train_error = float(percent_errors(d.cpu().numpy(), truth).mean())


def _validate(folder: RunFolder, model: torch.nn.Module, optimizer: torch.optim.Optimizer,
              validation: Validation, status: Status, add: AddRow, seconds: float, dev: torch.device) -> None:
    """Evaluate on the validation stores, log it, keep the best weights, checkpoint the run."""
    results = validation(model)
    for split, (loss, error) in results.items():
        add(status.iteration, seconds, split, loss, error)
    status.val = float(np.mean([e for _, e in results.values()]))
    add(status.iteration, seconds, VAL, float(np.mean([loss for loss, _ in results.values()])), status.val)
    if status.best is None or status.val < status.best:
        status.best, status.best_iteration = status.val, status.iteration
        _save(folder.file(BEST), Checkpoint(status.iteration, model.state_dict(), percent_error=status.val))
    for split, (_, error) in results.items():
        if split not in status.best_per_set or error < status.best_per_set[split][0]:
            status.best_per_set[split] = (error, status.iteration)
            _save(folder.file(best_of(split)), Checkpoint(status.iteration, model.state_dict(),
                                                          percent_error=error))
    _save(folder.file(LAST), Checkpoint(
        status.iteration, model.state_dict(), seconds=seconds, optimizer=optimizer.state_dict(),
        rng=torch.get_rng_state(), cuda_rng=torch.cuda.get_rng_state(dev) if dev.type == "cuda" else None,
        best=status.best, best_iteration=status.best_iteration, best_per_set=dict(status.best_per_set),
    ))
    status.checkpoint = status.iteration
