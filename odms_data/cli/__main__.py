"""`python -m odms_data.cli` runs the odms-data command line."""

from . import main

main(prog_name="odms-data")
