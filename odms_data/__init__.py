"""odms-data: generate, store, import and score ODMS (object depth via motion and segmentation) data.

The library API that the `odms-data` command line is a thin layer over:

    import odms_data
    odms_data.generate("train.zarr", 10_000, odms_data.preset("perturb"), seed=7, workers=2)
    with odms_data.open_store("train.zarr") as store:
        example = store.example(0)        # masks (n, H, W) bool, z, depth, d1, ...
"""

__version__ = "0.1.0"

from .errors import InputError, OdmsError, StoreError  # noqa: E402
from .importers.recording import import_recording  # noqa: E402
from .importers.release import import_release  # noqa: E402
from .simulate.generate_store import generate  # noqa: E402
from .simulate.object_model import PRESETS, GeneratorParams, preset  # noqa: E402
from .store.convert import convert  # noqa: E402
from .store.reader import Example, Store, open_store  # noqa: E402
from .store.validate import validate  # noqa: E402

__all__ = [
    "Example", "GeneratorParams", "InputError", "OdmsError", "PRESETS", "Store", "StoreError",
    "convert", "generate", "import_recording", "import_release", "open_store", "preset", "validate",
]
