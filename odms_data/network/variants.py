"""The networks `train` and `predict` know: the paper's three ODN variants and ODMD's DBox, each
with the label it learns, the inputs it sees and its authors' recipe.

Plain data, no PyTorch, so that the command line can offer the names without loading it; the
code that builds and runs each family of network is network/models.py.
"""

from __future__ import annotations

from dataclasses import dataclass

from ..errors import InputError
from ..simulate.box_examples import BOX_PRESETS
from ..simulate.params import PRESETS


@dataclass(frozen=True)
class Recipe:
    """A family's training defaults (its authors'), and the generator presets its stream may use."""

    preset: str
    presets: tuple[str, ...]
    iterations: int
    batch_size: int
    lr: float
    val_every: int
    radial: bool  # whether the family can take the radial image as an input


# ODN (ECCV 2020, section 4 and the released demo): Adam 1e-3, batches of 512, 5,000 iterations
ODN_RECIPE = Recipe("standard", tuple(PRESETS), 5000, 512, 1e-3, 10, radial=True)
# DBox (griffbr/ODMD, demo/demo_DBox_train.py with config/train/train_demo.yaml): Adam 1e-3, no weight
# decay, batches of 512, 100,000 iterations; the authors save 10 models and pick one on ODMD's val sets,
# here every 1,000 iterations are validated (a box validation is cheap)
DBOX_RECIPE = Recipe("odmd", tuple(BOX_PRESETS), 100_000, 512, 1e-3, 1000, radial=False)


@dataclass(frozen=True)
class Variant:
    """`family`: which network (models.py: odn or dbox); `label`: the loaders' label the network
    outputs (loaders/targets.py, or box_transform.py's `depth_norm`); `distances`: ODN's distance
    input beside the masks, `zbar` (n - 2 values) or `dz` (z_i - z_1 for i = 2..n); for DBox
    whether the label and movements are divided by the first movement's length (`normalized`)."""

    name: str
    paper: str
    label: str
    distances: str
    family: str = "odn"
    recipe: Recipe = ODN_RECIPE
    normalized: bool = True

    def n_distances(self, n_obs: int) -> int:
        return n_obs - 2 if self.distances == "zbar" else n_obs - 1


VARIANTS = {
    v.name: v
    for v in (
        Variant("odn-l", "ODN_l", "scale", "zbar"),  # relative scale d1/d_n, normalised distances
        Variant("odn-dbar", "ODN_dbar", "d1_norm", "zbar"),  # d1/(z_n - z_1), normalised distances
        Variant("odn-d", "ODN_d", "d1", "dz"),  # d1 in metres, distances in metres
        # depth / the first movement's length, movements so normalised, each relative to the previous
        Variant("dbox", "DBox", "depth_norm", "", "dbox", DBOX_RECIPE),
        # depth in metres, the movements as they are (config/model/DBox_absolute.yaml)
        Variant("dbox-abs", "DBox_Abs", "depth_norm", "", "dbox", DBOX_RECIPE, normalized=False),
    )
}


def variant(name: str) -> Variant:
    if name not in VARIANTS:
        raise InputError(f"unknown model '{name}'; choose from {', '.join(VARIANTS)}")
    return VARIANTS[name]
