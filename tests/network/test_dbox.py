"""DBox: the authors' architecture, parameter count and checkpoint format, and the checks made
before a checkpoint builds anything."""

from __future__ import annotations

import os
import pickle

import numpy as np
import pytest
import torch

from odms_data.errors import InputError
from odms_data.network.dbox import DBox, expected_shapes, load_pretrained

# The authors' DBox (griffbr/ODMD dbox/dbox.py with config/model/DBox.yaml, n_obs = num_pos = 10)
# counted by hand from its definition: W 7x512, U 128x512, bias 512, V 128x512; linears
# 198->256, five of 326->256, 256->1. Their DBox_pretrained_paper.pt holds this many values too.
AUTHORS_COUNT = 7 * 512 + 128 * 512 + 512 + 128 * 512 + (198 * 256 + 256) + 5 * (326 * 256 + 256) + 257


def parameter_count(model: torch.nn.Module) -> int:
    return sum(p.numel() for p in model.parameters() if p.requires_grad)


def test_parameter_count_is_the_authors():
    assert AUTHORS_COUNT == 604_929
    assert parameter_count(DBox()) == AUTHORS_COUNT


def test_state_dict_names_and_shapes_are_the_authors():
    assert {k: tuple(v.shape) for k, v in DBox().state_dict().items()} == expected_shapes()


def test_initial_weights_are_the_authors():
    # The authors' DBox.__init__ (dbox/dbox.py) makes W, U, bias, V, calls init_weights(), which
    # draws every parameter existing so far from U(+-1/sqrt(hidden)), and only then makes the
    # linears, which keep PyTorch's default init. Their draws, in their order, under one seed:
    torch.manual_seed(3)
    lstm = [torch.empty(7, 512), torch.empty(128, 512), torch.empty(512), torch.empty(128, 512)]
    for t in lstm:
        t.uniform_(-1 / 128 ** 0.5, 1 / 128 ** 0.5)
    linears = [torch.nn.Linear(198, 256), *(torch.nn.Linear(326, 256) for _ in range(5)),
               torch.nn.Linear(256, 1)]
    theirs = dict(zip(["W", "U", "bias", "V"], lstm, strict=True))
    for k, layer in enumerate(linears):
        theirs[f"linears.{k}.weight"], theirs[f"linears.{k}.bias"] = layer.weight, layer.bias
    torch.manual_seed(3)
    ours = DBox().state_dict()
    assert list(ours) == list(theirs)
    assert all(torch.equal(ours[k], theirs[k]) for k in ours)
    # PyTorch's default bound for a linear, 1/sqrt(fan_in), not the LSTM's 1/sqrt(128)
    assert 0.9 / 326 ** 0.5 < ours["linears.3.weight"].abs().max() <= 1 / 326 ** 0.5


def _sigmoid(a):
    return 1 / (1 + np.exp(-a))


def test_forward_is_the_peephole_lstm_and_dense_layers():
    torch.manual_seed(0)
    model = DBox().double()
    x = torch.randn(3, 10, 7, dtype=torch.float64)
    p = {k: v.detach().numpy() for k, v in model.state_dict().items()}
    hs = 128
    h = np.zeros((3, hs))
    c = np.zeros((3, hs))
    xs = x.numpy()
    for t in range(10):
        base = xs[:, t] @ p["W"] + h @ p["U"] + p["bias"]
        before = base + c @ p["V"]  # the input, forget and candidate gates see the old cell state
        c = _sigmoid(before[:, hs:2 * hs]) * c + _sigmoid(before[:, :hs]) * np.tanh(before[:, 2 * hs:3 * hs])
        h = _sigmoid((base + c @ p["V"])[:, 3 * hs:]) * np.tanh(c)  # the output gate the new one
    d = h
    flat = xs.reshape(3, 70)
    for k in range(6):
        d = np.maximum(np.concatenate([d, flat], 1) @ p[f"linears.{k}.weight"].T + p[f"linears.{k}.bias"], 0)
    want = (d @ p["linears.6.weight"].T + p["linears.6.bias"])[:, 0]
    with torch.no_grad():
        np.testing.assert_allclose(model(x).numpy(), want, rtol=1e-10, atol=1e-12)


def test_forward_refuses_other_shapes():
    with pytest.raises(InputError, match=r"\(batch, 10, 7\)"):
        DBox()(torch.zeros(2, 9, 7))


def test_saved_state_dict_loads_back(tmp_path):
    model = DBox().eval()
    torch.save(model.state_dict(), tmp_path / "m.pt")
    x = torch.randn(4, 10, 7)
    with torch.no_grad():
        assert torch.equal(load_pretrained(tmp_path / "m.pt").eval()(x), model(x))


def test_wrong_shape_or_names_refused(tmp_path):
    state = DBox().state_dict()
    state["V"] = torch.zeros(128, 4)
    torch.save(state, tmp_path / "shape.pt")
    with pytest.raises(InputError, match="parameter V"):
        load_pretrained(tmp_path / "shape.pt")
    state = DBox().state_dict()
    state["extra"] = torch.zeros(1)
    torch.save(state, tmp_path / "extra.pt")
    with pytest.raises(InputError, match="extra"):
        load_pretrained(tmp_path / "extra.pt")


class _Runs:
    def __reduce__(self):
        return (os.system, ("echo ran > ran.txt",))


def test_a_checkpoint_carrying_code_runs_nothing(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "evil.pt").write_bytes(pickle.dumps({"W": _Runs()}))
    with pytest.raises(InputError, match="refused: it names posix.system"):
        load_pretrained(tmp_path / "evil.pt")
    assert not (tmp_path / "ran.txt").exists()


def test_missing_and_oversized_files_refused(tmp_path):
    with pytest.raises(InputError, match="none.pt: no such checkpoint"):
        load_pretrained(tmp_path / "none.pt")
    big = tmp_path / "big.pt"
    with open(big, "wb") as f:
        f.truncate((64 << 20) + 1)
    with pytest.raises(InputError, match="larger than 64 MiB"):
        load_pretrained(big)


def test_authors_checkpoint_loads(odmd_pretrained):
    model = load_pretrained(odmd_pretrained)
    assert parameter_count(model) == AUTHORS_COUNT
