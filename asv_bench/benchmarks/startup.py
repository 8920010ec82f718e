"""Start-up cost, each in a fresh interpreter: importing the package, and the command line's
`--help`."""

from __future__ import annotations


def timeraw_import_package() -> str:
    return "import odms_data"


def timeraw_cli_help() -> str:
    return """
import contextlib, io
from odms_data.cli import main
with contextlib.redirect_stdout(io.StringIO()):
    main(["--help"], standalone_mode=False)
"""
