"""What training, validation and prediction need of a family of networks, one entry per family:
its network, its stream of generated training batches, a store's examples as its inputs, and
its output read back as a depth. training.py and prediction.py call these and nothing
family-specific; the recipe's defaults are plain data in variants.py.

    odn   ODN (ECCV 2020) on masks and camera positions: odn.py, loaders/transforms.py
    dbox  DBox (CVPR 2021) on boxes and camera movements: dbox.py, loaders/box_transform.py
"""

from __future__ import annotations

import os
from abc import ABC, abstractmethod
from dataclasses import replace

import torch
from torch import nn

from ..errors import InputError
from ..loaders.box_transform import BoxTransform
from ..loaders.targets import depth
from ..loaders.torch_loader import StoreDataset, StreamDataset
from ..simulate.box_examples import BOX_PRESETS
from ..simulate.params import PRESETS, GeneratorParams
from . import dbox, odn
from .run_folder import TrainConfig
from .variants import variant

Batch = dict[str, torch.Tensor]  # a loader batch: network inputs and labels by name


class Model(ABC):
    """A family of networks. `truth`: the batch's depth (m) that predictions are scored against;
    the L1 loss is between the network's output and the batch's `variant.label`."""

    truth: str

    def __init__(self, config: TrainConfig) -> None:
        self.config, self.variant = config, variant(config.model)

    @abstractmethod
    def build(self) -> nn.Module:
        """The network with fresh weights (drawn from torch's global generator)."""

    @abstractmethod
    def stream(self, start: int) -> StreamDataset:
        """The training batches from batch `start` on: batch b depends only on (config, b)."""

    @abstractmethod
    def store_dataset(self, path: str) -> StoreDataset:
        """A store's examples as the network's inputs; its open store is `.examples.store`."""

    @abstractmethod
    def outputs_and_depths(self, net: nn.Module, batch: Batch) -> tuple[torch.Tensor, torch.Tensor]:
        """The network's outputs for a batch (on the network's device) and the depths they mean
        (float64)."""

    @abstractmethod
    def kept(self) -> tuple[str, ...]:
        """The batch keys validation keeps on the device: inputs, label and truth."""

    def load_file(self, path: str | os.PathLike[str]) -> nn.Module:
        """The network with the weights of a state dict file that is not a run's checkpoint."""
        raise InputError(f"{path}: {self.config.model} predicts from a training run's folder, not a weights "
                         "file")


class OdnModel(Model):
    truth = "d1"

    def build(self) -> nn.Module:
        return odn.build(self.variant, self.config.n_obs, self.config.radial)

    def stream_params(self) -> GeneratorParams:
        """The generator's parameters for the stream: the preset's (10 observations, of which the
        network sees n_obs evenly spaced ones, as the authors' demo does), more when n_obs asks."""
        params = PRESETS[self.config.preset]
        return params if self.config.n_obs <= params.n_obs else replace(params, n_obs=self.config.n_obs)

    def stream(self, start: int) -> StreamDataset:
        c = self.config
        return StreamDataset(c.batch_size, c.iterations, params=self.stream_params(), seed=c.seed,
                             transform=odn.transform(c.n_obs, c.radial), start=start)

    def store_dataset(self, path: str) -> StoreDataset:
        return StoreDataset(path, odn.transform(self.config.n_obs, self.config.radial))

    def outputs_and_depths(self, net: nn.Module, batch: Batch) -> tuple[torch.Tensor, torch.Tensor]:
        # float64: d1 = s span / (1 - s) magnifies float32 rounding where the scale s is near 1
        out = net(*odn.inputs(batch, self.variant))
        return out, depth(self.variant.label, out.detach().double(), batch["dz"][:, -1].double())

    def kept(self) -> tuple[str, ...]:
        return ("masks", "radial", self.variant.distances, self.variant.label, "dz", "d1")


class DBoxModel(Model):
    truth = "depth"

    def transform(self) -> BoxTransform:
        """DBox's inputs: the movements and label normalised (DBox) or not (DBox_Abs), and each
        movement relative to the previous observation's or not, as the authors' two configs."""
        v = self.variant
        return BoxTransform(self.config.n_obs, normalized=v.normalized, relative=v.normalized)

    def build(self) -> nn.Module:
        return dbox.DBox(self.config.n_obs)

    def stream(self, start: int) -> StreamDataset:
        c = self.config
        return StreamDataset(c.batch_size, c.iterations, params=BOX_PRESETS[c.preset], seed=c.seed,
                             transform=self.transform(), start=start)

    def store_dataset(self, path: str) -> StoreDataset:
        return StoreDataset(path, self.transform())

    def outputs_and_depths(self, net: nn.Module, batch: Batch) -> tuple[torch.Tensor, torch.Tensor]:
        out = net(batch["inputs"])
        return out, out.detach().double() * batch["norm"].double()

    def kept(self) -> tuple[str, ...]:
        return ("inputs", self.variant.label, "norm", "depth")

    def load_file(self, path: str | os.PathLike[str]) -> nn.Module:
        return dbox.load_pretrained(path, self.config.n_obs)


MODEL_CLASSES: dict[str, type[Model]] = {"odn": OdnModel, "dbox": DBoxModel}


def model_of(config: TrainConfig) -> Model:
    return MODEL_CLASSES[variant(config.model).family](config)
