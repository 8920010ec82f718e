"""What training and prediction share to run a network: the device, a store's examples as batches
on it, and a checkpoint read back (models.py: the network, its inputs and the depths it means)."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import torch
from torch.utils.data import DataLoader, Dataset

from ..errors import InputError, OdmsError
from ..pickles import load_checkpoint
from .checkpoint import Checkpoint
from .models import Batch

EVAL_BATCH = 256  # examples a forward pass in evaluation


def pick_device(name: str | None) -> torch.device:
    """The device called `name`, or the first GPU when there is one, else the CPU."""
    if name is None:
        return torch.device("cuda" if torch.cuda.is_available() else "cpu")
    try:
        device = torch.device(name)
    except RuntimeError:
        raise InputError(f"device '{name}' is not a device name (cpu, cuda, cuda:1, ...)") from None
    if device.type not in ("cpu", "cuda"):  # meta, xla, ...: no place to train or predict on
        raise InputError(f"device {name}: not a device odms-data computes on; use cpu, cuda or cuda:N")
    if device.type == "cuda" and not torch.cuda.is_available():
        raise InputError(f"device {name}: PyTorch sees no CUDA device on this machine")
    if device.type == "cuda" and (device.index or 0) >= torch.cuda.device_count():
        raise InputError(f"device {name}: this machine has {torch.cuda.device_count()} CUDA device(s)")
    return device


def to_device(batch: Batch, device: torch.device) -> Batch:
    return {k: t.to(device, non_blocking=True) for k, t in batch.items()}


WORKER_ERROR = "in DataLoader worker process"  # how torch says an exception came from a worker


def eval_batches(dataset: Dataset, workers: int, pin: bool) -> Iterator[Batch]:
    """The store's examples as network inputs, in row order, EVAL_BATCH at a time. A problem a
    worker meets (a damaged chunk) is raised with its own one-line message: torch raises it again
    with the worker's traceback as its message."""
    try:
        yield from DataLoader(dataset, batch_size=EVAL_BATCH, num_workers=workers, pin_memory=pin)
    except OdmsError as e:
        if WORKER_ERROR not in str(e):
            raise
        raise type(e)(str(e).rstrip().splitlines()[-1].split(": ", 1)[-1]) from None


def read_checkpoint(path: Path) -> Checkpoint:
    """A checkpoint, on the CPU (the random states must be there; load_state_dict moves weights
    and Adam's state to their module's device), read within pickles.load_checkpoint's bounds."""
    return Checkpoint.from_json(load_checkpoint(path), str(path))
