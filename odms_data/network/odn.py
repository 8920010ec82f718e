"""ODN's architecture as the authors configured it (their released `config/odn*.yaml`).

Input: the n masks at 112x112 as channels (plus the radial image for the `r` variants) and a
vector of k camera distances (k = n - 2 for ODN_l and ODN_dbar, n - 1 for ODN_d).

    conv 14x14, stride 2, padding 3, no bias -> batch norm -> ReLU     32 x 53 x 53
    residual block, stride 2                                            64 x 27 x 27
    residual block, stride 2                                           128 x 14 x 14
    residual block, stride 2                                           128 x  7 x  7
    residual block, stride 2                                           256 x  4 x  4
    average pool 4x4                                                   256
    [features, distances] -> linear 256 -> ReLU -> dropout 20 %         256
    [hidden, distances] -> linear 1                                     the output

A residual block is two 3x3 convolutions without bias, each followed by batch norm (ReLU
between them and after the sum), with a 1x1 convolution and batch norm on the shortcut where
the shape changes (here: every block). Parameters: 1,656,137 for ODN_l with the radial image,
1,649,865 for ODN_l and ODN_dbar without it, 1,650,122 for ODN_d (n = 10).
"""

from __future__ import annotations

import itertools

import torch
from torch import nn

from ..errors import InputError
from ..loaders.transforms import PAPER_SIZE, Transform
from .variants import Variant

STEM = 32
WIDTHS = (64, 128, 128, 256)
HIDDEN = 256
DROPOUT = 0.2


class ResidualBlock(nn.Module):
    def __init__(self, inputs: int, outputs: int, stride: int) -> None:
        super().__init__()
        self.conv1 = nn.Conv2d(inputs, outputs, 3, stride=stride, padding=1, bias=False)
        self.bn1 = nn.BatchNorm2d(outputs)
        self.conv2 = nn.Conv2d(outputs, outputs, 3, padding=1, bias=False)
        self.bn2 = nn.BatchNorm2d(outputs)
        self.shortcut: nn.Module = nn.Identity()
        if stride != 1 or inputs != outputs:
            self.shortcut = nn.Sequential(nn.Conv2d(inputs, outputs, 1, stride=stride, bias=False),
                                          nn.BatchNorm2d(outputs))

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        y = torch.relu(self.bn1(self.conv1(x)))
        return torch.relu(self.bn2(self.conv2(y)) + self.shortcut(x))


class ODN(nn.Module):
    """`channels` input images (n masks, plus 1 with the radial image), `n_distances` distances;
    forward(images (B, channels, 112, 112), distances (B, n_distances)) -> outputs (B,)."""

    def __init__(self, channels: int, n_distances: int) -> None:
        super().__init__()
        self.stem = nn.Sequential(nn.Conv2d(channels, STEM, 14, stride=2, padding=3, bias=False),
                                  nn.BatchNorm2d(STEM), nn.ReLU())
        widths = (STEM, *WIDTHS)
        self.blocks = nn.Sequential(*(ResidualBlock(a, b, 2) for a, b in itertools.pairwise(widths)))
        self.pool = nn.AvgPool2d(4)
        self.hidden = nn.Linear(WIDTHS[-1] + n_distances, HIDDEN)
        self.dropout = nn.Dropout(DROPOUT)
        self.out = nn.Linear(HIDDEN + n_distances, 1)

    def forward(self, images: torch.Tensor, distances: torch.Tensor) -> torch.Tensor:
        x = self.pool(self.blocks(self.stem(images))).flatten(1)
        x = self.dropout(torch.relu(self.hidden(torch.cat([x, distances], 1))))
        return self.out(torch.cat([x, distances], 1)).squeeze(1)


def build(v: Variant, n_obs: int, radial: bool) -> ODN:
    """The network of variant `v` for n_obs observations, with or without the radial image, its
    convolutions in the channels-last layout (the same network, faster on a CPU:
    benchmarks/train_step.py)."""
    if n_obs < 2:
        raise InputError(f"ODN needs at least 2 observations, got n_obs={n_obs}")
    model = ODN(n_obs + radial, v.n_distances(n_obs))
    return model.to(memory_format=torch.channels_last)  # type: ignore[call-overload]  # not in Module.to's stubs


def transform(n_obs: int, radial: bool) -> Transform:
    """The loaders' transform that makes ODN's inputs: the default one (the paper's float32
    coverage masks at 112x112, dz_2..dz_n, zbar), for n_obs observations."""
    return Transform(size=PAPER_SIZE, n_obs=n_obs, radial=radial)


def inputs(batch: dict[str, torch.Tensor], v: Variant) -> tuple[torch.Tensor, torch.Tensor]:
    """(images, distances) of a loader batch for variant `v`; the images channels-last, as build()'s
    network takes them."""
    images = batch["masks"]
    if "radial" in batch:
        images = torch.cat([images, batch["radial"]], 1)
    images = images.contiguous(memory_format=torch.channels_last)
    return images, batch[v.distances]
