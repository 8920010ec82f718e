"""The paper's three ODN variants: which label each learns and which camera distances it sees.

Plain data, no PyTorch, so that the command line can offer the names without loading it.
"""

from __future__ import annotations

from dataclasses import dataclass

from ..errors import InputError


@dataclass(frozen=True)
class Variant:
    """`label`: the loaders' label the network outputs (loaders/targets.py); `distances`: the
    loaders' distance input beside it, `zbar` (n - 2 values) or `dz` (z_i - z_1 for i = 2..n)."""

    name: str
    paper: str
    label: str
    distances: str

    def n_distances(self, n_obs: int) -> int:
        return n_obs - 2 if self.distances == "zbar" else n_obs - 1


VARIANTS = {
    v.name: v
    for v in (
        Variant("odn-l", "ODN_l", "scale", "zbar"),  # relative scale d1/d_n, normalised distances
        Variant("odn-dbar", "ODN_dbar", "d1_norm", "zbar"),  # d1/(z_n - z_1), normalised distances
        Variant("odn-d", "ODN_d", "d1", "dz"),  # d1 in metres, distances in metres
    )
}


def variant(name: str) -> Variant:
    if name not in VARIANTS:
        raise InputError(f"unknown model '{name}'; choose from {', '.join(VARIANTS)}")
    return VARIANTS[name]
