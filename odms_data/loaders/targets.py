"""What the network learns: the paper's three labels of an example."""

from __future__ import annotations

import numpy as np


def labels(d1: float, z: np.ndarray) -> dict[str, np.float32]:
    """The paper's three labels of an example with label d1 and camera positions z."""
    span = float(z[-1] - z[0])
    return {
        "d1": np.float32(d1),
        "d1_norm": np.float32(d1 / span),
        "scale": np.float32(d1 / (d1 + span)),
    }
