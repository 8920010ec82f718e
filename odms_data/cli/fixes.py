"""How the command line says what a library error names: each `OdmsError.fix` spelled with the
options of the commands, and each `OdmsError.option` written as its flag."""

from __future__ import annotations

from ..errors import OdmsError
from ..evaluation.ground_truth import DEFAULT_DATA, ENV_VAR

FIXES = {
    "overwrite": "pass --overwrite to replace it",
    "overwrite-ours": "--overwrite replaces only what odms-data wrote, so move it away or choose another "
                      "output",
    "overwrite-store": "--overwrite replaces only an odms-data store or an empty folder, so move it away or "
                       "choose another output",
    "overwrite-url-store": "--overwrite replaces only an odms-data store, so choose another output",
    "overwrite-run": "give another folder, or --overwrite to start this one again",
    "name-zarr": "name it *.zarr or ask for --format hdf5",
    "name-hdf5": "name it *.h5 or ask for --format zarr",
    "allow-partial": "pass --allow-partial to score a subset",
    "complete-score": "drop --allow-partial",
    "skip-bad": "--skip-bad imports the rest",
    "import": "see `odms-data import`",
    "synthia-selection": "see --frames, --move, --d1-range, --min-area in schemas/SYNTHIA.md; when the "
                         "camera moves towards the objects, --forward may have the wrong sign",
    "data": f"give --data DIR or set {ENV_VAR}; default {DEFAULT_DATA}",
    "no-stores": f"give --data DIR or set {ENV_VAR} (see `odms-data generate` and `odms-data import`)",
    "licence": "give --license (the Hub's licence id, e.g. cc-by-4.0, or other)",
    "matrix-order-row-major": "if the numbers are row-major, say --matrix-order row-major",
    "matrix-order-column-major": "if the numbers are column-major, say --matrix-order column-major",
    "pose-world-to-camera": "--pose is probably wrong: if the matrices map the world to the camera, say "
                            "--pose world-to-camera",
    "pose-camera-to-world": "--pose is probably wrong: SYNTHIA's matrices map the camera to the world, so "
                            "say --pose camera-to-world (the default)",
}

FLAGS = {  # the library's name of an input -> the option that gives it
    "output": "-o",
    "plot": "--plot",
    "entry": "--entry",
    "classes": "--classes",
    "frames": "--frames",
    "move": "--move",
    "d1": "--d1-range",
}


def with_fix(e: BaseException) -> str:
    """The error's message, the input it starts with written as its flag, and how to fix it with
    the command line's options when it names a fix."""
    text = str(e)
    if not isinstance(e, OdmsError):
        return text
    if e.option in FLAGS and text.startswith(e.option):
        text = FLAGS[e.option] + text[len(e.option):]
    fix = FIXES.get(e.fix)
    return f"{text}; {fix}" if fix else text
