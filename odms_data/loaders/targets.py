"""What the network learns: the paper's three labels of an example, and each one back to a depth.

An example with label d1 (m) and camera positions z_1 < ... < z_n has the span s = z_n - z_1 and:

- `d1`: the depth itself (ODN_d);
- `d1_norm` = d1 / s, the depth in units of the camera's travel (ODN_dbar);
- `scale` = d1 / d_n = l_n / l_1, the relative scale of the object between the last and the first
  observation, d_n = d1 + s for a still object and a camera moving along its axis (ODN_l).

`depth(label, output, span)` inverts each: it is how a network's output becomes a predicted d1.
It is plain arithmetic, so it works on floats, NumPy arrays and torch tensors alike.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..errors import InputError


def labels(d1: float, z: np.ndarray) -> dict[str, np.float32]:
    """The paper's three labels of an example with label d1 and camera positions z."""
    span = float(z[-1] - z[0])
    return {
        "d1": np.float32(d1),
        "d1_norm": np.float32(d1 / span),
        "scale": np.float32(d1 / (d1 + span)),
    }


def depth(label: str, output: Any, span: Any) -> Any:
    """d1 from a prediction of `label` for examples whose camera travelled `span` = z_n - z_1."""
    if label == "d1":
        return output
    if label == "d1_norm":
        return output * span
    if label == "scale":  # s = d1 / (d1 + span)  <=>  d1 = s span / (1 - s)
        return output * span / (1 - output)
    raise InputError(f"unknown label '{label}'; the labels are d1, d1_norm and scale")
