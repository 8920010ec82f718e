"""How the command line fixes what a library error names: each `OdmsError.fix` spelled with the
options of the commands."""

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
}


def with_fix(e: BaseException) -> str:
    """The error's message, and how to fix it with the command line's options when it names a fix."""
    fix = FIXES.get(getattr(e, "fix", "") if isinstance(e, OdmsError) else "")
    return f"{e}; {fix}" if fix else str(e)
