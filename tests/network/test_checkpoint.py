"""The Checkpoint record: the keys best.pt and last.pt hold, and what is not a checkpoint."""

from __future__ import annotations

import pytest
import torch

from odms_data.errors import InputError
from odms_data.network.checkpoint import Checkpoint


def test_best_and_last_keep_their_keys_in_order():
    weights = {"w": torch.zeros(2)}
    best = Checkpoint(7, weights, percent_error=12.5)
    assert list(best.to_json()) == ["iteration", "model", "percent_error"]
    last = Checkpoint(7, weights, seconds=1.5, optimizer={"state": {}}, rng=torch.get_rng_state(), best=12.5,
                      best_iteration=7)
    assert list(last.to_json()) == ["iteration", "seconds", "model", "optimizer", "rng", "best",
                                    "best_iteration"]
    again = Checkpoint.from_json(last.to_json(), "last.pt")
    assert again.iteration == 7 and again.resume_state("last.pt")[2] == 1.5
    with pytest.raises(InputError, match="best.pt: a run cannot resume from it"):
        Checkpoint.from_json(best.to_json(), "best.pt").resume_state("best.pt")


@pytest.mark.parametrize(("content", "message"), [
    ({"weights": {}}, "not an odms-data checkpoint"),
    ({"iteration": 1, "model": {}, "extra": 1}, "unknown key 'extra'"),
    ({"iteration": -1, "model": {}}, "iteration -1 is not a whole number"),
    ({"iteration": 1, "model": [1]}, "holds no weights"),
])
def test_what_is_not_a_checkpoint_is_named(content, message):
    with pytest.raises(InputError, match=message):
        Checkpoint.from_json(content, "x.pt")
