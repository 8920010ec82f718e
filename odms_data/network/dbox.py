"""DBox (Griffin & Corso, CVPR 2021) as the authors configured it (griffbr/ODMD,
config/model/DBox.yaml and dbox/dbox.py): a peephole LSTM over the observations, then fully
connected layers that each also see every observation's input.

Input: (B, n_obs, 7) from loaders/box_transform.py, n_obs = 10.

    LSTM, 1 observation a step, 128 hidden units; gates = x W + h U + bias + c V, with V a full
      128 x 512 matrix on the cell state: the input, forget and candidate gates see the previous
      cell state, the output gate the new one
    [h_n, all inputs (70)] -> linear 256 -> ReLU, six times        256
    linear 1                                                        the output

Parameters for n_obs = 10: LSTM 7*512 + 128*512 + 512 + 128*512 = 135,168; linears
(128+70)*256 + 256 = 50,944, then five of (256+70)*256 + 256 = 83,712, then 257: 604,929 in all.
The parameter names are the authors' (W, U, bias, V, linears.k), so their checkpoints load as
they are. The initial weights are the authors' too: W, U, bias and V from U(+-1/sqrt(128)), drawn in
that order, then the linears with PyTorch's default; under one torch seed the two models start equal.
"""

from __future__ import annotations

import math
import os

import torch
from torch import nn

from ..errors import InputError
from ..loaders.box_transform import DBOX_OBS, FEATURES
from ..pickles import load_checkpoint

HIDDEN = 128
FCS = (256,) * 6


class DBox(nn.Module):
    """forward(inputs (B, n_obs, 7)) -> outputs (B,)."""

    def __init__(self, n_obs: int = DBOX_OBS, hidden: int = HIDDEN, fcs: tuple[int, ...] = FCS) -> None:
        super().__init__()
        if n_obs < 2:
            raise InputError(f"DBox needs at least 2 observations, got n_obs={n_obs}")
        self.n_obs, self.hidden = n_obs, hidden
        self.W = nn.Parameter(torch.empty(FEATURES, 4 * hidden))
        self.U = nn.Parameter(torch.empty(hidden, 4 * hidden))
        self.bias = nn.Parameter(torch.empty(4 * hidden))
        self.V = nn.Parameter(torch.empty(hidden, 4 * hidden))
        bound = 1 / math.sqrt(hidden)  # the authors' init_weights() runs here, before the linears
        for p in (self.W, self.U, self.bias, self.V):  # exist: it draws the LSTM's alone, in this order
            nn.init.uniform_(p, -bound, bound)
        seen = n_obs * FEATURES
        widths = (hidden, *fcs)  # the linears keep PyTorch's default init, as the authors' do
        self.linears = nn.ModuleList([nn.Linear(a + seen, b) for a, b in zip(widths, fcs, strict=False)])
        self.linears.append(nn.Linear(fcs[-1], 1))

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        b, n, f = x.shape
        if (n, f) != (self.n_obs, FEATURES):
            raise InputError(f"DBox takes inputs (batch, {self.n_obs}, {FEATURES}), got {tuple(x.shape)}")
        hs = self.hidden
        h = x.new_zeros(b, hs)
        c = x.new_zeros(b, hs)
        for t in range(n):
            step = x[:, t] @ self.W + h @ self.U + self.bias
            gates = step + c @ self.V
            i, f_ = torch.sigmoid(gates[:, :hs]), torch.sigmoid(gates[:, hs:2 * hs])
            c = f_ * c + i * torch.tanh(gates[:, 2 * hs:3 * hs])
            o = torch.sigmoid((step + c @ self.V)[:, 3 * hs:])
            h = o * torch.tanh(c)
        seen = x.reshape(b, n * f)
        d = h
        for layer in self.linears[:-1]:
            d = torch.relu(layer(torch.cat([d, seen], 1)))
        return self.linears[-1](d).squeeze(1)


def expected_shapes(n_obs: int = DBOX_OBS) -> dict[str, tuple[int, ...]]:
    """Every parameter's name and shape in DBox's state dict, without building the network."""
    seen = n_obs * FEATURES
    shapes: dict[str, tuple[int, ...]] = {
        "W": (FEATURES, 4 * HIDDEN), "U": (HIDDEN, 4 * HIDDEN),
        "bias": (4 * HIDDEN,), "V": (HIDDEN, 4 * HIDDEN),
    }
    widths = (HIDDEN, *FCS)
    for k, (a, b) in enumerate(zip(widths, FCS, strict=False)):
        shapes[f"linears.{k}.weight"], shapes[f"linears.{k}.bias"] = (b, a + seen), (b,)
    shapes[f"linears.{len(FCS)}.weight"], shapes[f"linears.{len(FCS)}.bias"] = (1, FCS[-1]), (1,)
    return shapes


def load_pretrained(path: str | os.PathLike[str], n_obs: int = DBOX_OBS) -> DBox:
    """DBox with the weights of the state dict at `path` (the authors' DBox_pretrained_paper.pt, or
    one saved from DBox.state_dict()): read within pickles.load_checkpoint's bounds, its names,
    shapes and dtypes checked against DBox's before the network is built."""
    state = load_checkpoint(path)
    if not isinstance(state, dict) or not all(isinstance(v, torch.Tensor) for v in state.values()):
        raise InputError(f"{path}: not a state dict of tensors")
    want = expected_shapes(n_obs)
    if set(state) != set(want):
        odd = sorted(set(state) ^ set(want))
        raise InputError(f"{path}: not DBox's parameters for n_obs={n_obs} (differs in {', '.join(odd[:4])})")
    for name, shape in want.items():
        t = state[name]
        if tuple(t.shape) != shape or t.dtype != torch.float32:
            raise InputError(f"{path}: parameter {name} is {t.dtype} {tuple(t.shape)}, "
                             f"DBox's is float32 {shape}")
    model = DBox(n_obs)
    model.load_state_dict(state)
    return model
