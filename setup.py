"""Build hook: ship schemas/, splits/ and leaderboard/ inside the package.

They stay at the top of the source tree (the project's layout), and a built package carries a
copy in odms_data/_shipped/, next to the code, so every kind of install (wheel, --user, --prefix,
--target) finds them; an editable install reads them from the source tree (odms_data/resources.py).
"""

import shutil
from pathlib import Path

from setuptools import setup
from setuptools.command.build_py import build_py

SHIPPED = ("schemas", "splits", "leaderboard")


class BuildPyWithShippedFiles(build_py):
    def run(self) -> None:
        super().run()
        if getattr(self, "editable_mode", False):
            return
        root = Path(__file__).resolve().parent
        for name in SHIPPED:
            target = Path(self.build_lib) / "odms_data" / "_shipped" / name
            shutil.rmtree(target, ignore_errors=True)
            shutil.copytree(root / name, target)


setup(cmdclass={"build_py": BuildPyWithShippedFiles})
