"""odms-data: generate, store, import and score ODMS (object depth via motion and segmentation) data.

The library API that the `odms-data` command line is a thin layer over:

    import odms_data
    odms_data.generate("train.zarr", 10_000, odms_data.preset("perturb"), seed=7, workers=2)
    with odms_data.open_store("train.zarr") as store:
        example = store.example(0)        # masks (n, H, W) bool, z, depth, d1, ...
        boxes = odms_data.example_boxes(store, [0])  # ODMD's boxes (Griffin & Corso, CVPR 2021)

The names below are loaded on first use, so `import odms_data` costs almost nothing; the layers
they come from (store/, simulate/, importers/, evaluation/, loaders/, cli/) are described in
their folders' docstrings.
"""

from __future__ import annotations

from importlib import import_module
from typing import TYPE_CHECKING, Any

from ._version import __version__

_EXPORTS = {
    "Example": "store.reader", "Store": "store.reader", "open_store": "store.reader",
    "convert": "store.convert", "validate": "store.validate",
    "InputError": "errors", "OdmsError": "errors", "StoreError": "errors",
    "GeneratorParams": "simulate.params", "PRESETS": "simulate.params",
    "preset": "simulate.params", "generate": "simulate.generate_store",
    "import_release": "importers.release", "import_recording": "importers.recording",
    "import_synthia": "importers.synthia",
    # ODMD's: examples of boxes, read from any store, generated, imported; its baseline
    "BoxExamples": "store.box_rule", "example_boxes": "store.box_rule",
    "generate_box_store": "simulate.generate_box_store", "import_odmd": "importers.odmd",
    "box_ls": "evaluation.box_ls",
    # the loaders' sources, of either kind: masks, or boxes (a BoxTransform, or box parameters)
    "StoreExamples": "loaders.sources", "GeneratedExamples": "loaders.sources",
    "BoxTransform": "loaders.box_transform",
}
__all__ = [
    "PRESETS", "BoxExamples", "BoxTransform", "Example", "GeneratedExamples", "GeneratorParams", "InputError",
    "OdmsError", "Store", "StoreError", "StoreExamples", "__version__", "box_ls", "convert", "example_boxes",
    "generate", "generate_box_store", "import_odmd", "import_recording", "import_release", "import_synthia",
    "open_store", "preset", "validate",
]

if TYPE_CHECKING:
    from .errors import InputError, OdmsError, StoreError
    from .evaluation.box_ls import box_ls
    from .importers.odmd import import_odmd
    from .importers.recording import import_recording
    from .importers.release import import_release
    from .importers.synthia import import_synthia
    from .loaders.box_transform import BoxTransform
    from .loaders.sources import GeneratedExamples, StoreExamples
    from .simulate.generate_box_store import generate_box_store
    from .simulate.generate_store import generate
    from .simulate.params import PRESETS, GeneratorParams, preset
    from .store.box_rule import BoxExamples, example_boxes
    from .store.convert import convert
    from .store.reader import Example, Store, open_store
    from .store.validate import validate


def __getattr__(name: str) -> Any:
    if name not in _EXPORTS:
        raise AttributeError(f"module 'odms_data' has no attribute {name!r}")
    value = getattr(import_module(f".{_EXPORTS[name]}", __name__), name)
    globals()[name] = value  # later lookups skip this function
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_EXPORTS))
