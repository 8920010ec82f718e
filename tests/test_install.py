"""A built wheel works wherever pip puts it: installed with --prefix, --target and --user into
temporary folders, it finds its shipped schemas/ and splits/ (also from worker processes) and
generates a named split whose digest matches its manifest."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import sysconfig
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
NOT_SOURCE = shutil.ignore_patterns(".*", "build", "dist", "*.egg-info", "__pycache__", "tests", "benchmarks")


@pytest.fixture(scope="module")
def wheel(tmp_path_factory) -> Path:
    src, dist = tmp_path_factory.mktemp("src"), tmp_path_factory.mktemp("dist")
    shutil.copytree(REPO, src, ignore=NOT_SOURCE, dirs_exist_ok=True)
    subprocess.run([sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation", "-q",
                    "-w", str(dist), str(src)], check=True)
    (found,) = dist.glob("odms_data-*.whl")
    return found


def _install(wheel: Path, option: str, where: Path) -> tuple[str, dict[str, str], Path]:
    """Install the wheel with pip's `option`; (python, environment, folder holding the package)."""
    if option == "--user":  # outside the virtual environment, which has no user site
        python = getattr(sys, "_base_executable", sys.executable)
        env = {**os.environ, "PYTHONUSERBASE": str(where), "PYTHONPATH": sysconfig.get_paths()["purelib"]}
        subprocess.run([python, "-m", "pip", "install", "--no-deps", "--user", "-q", str(wheel)], env=env,
                       check=True, stderr=subprocess.DEVNULL)  # pip warns about running as root
        (site,) = where.glob("lib/python*/site-packages")
        return python, env, site
    pip = [sys.executable, "-m", "pip", "install", "--no-deps", "--ignore-installed", "-q"]
    subprocess.run([*pip, option, str(where), str(wheel)], check=True)
    site = where if option == "--target" else next(where.glob("lib/python*/site-packages"))
    return sys.executable, {**os.environ, "PYTHONPATH": str(site)}, site


@pytest.mark.parametrize("option, workers", [("--prefix", "2"), ("--target", "1"), ("--user", "2")])
def test_an_installed_wheel_generates_a_named_split(wheel, tmp_path, option, workers):
    python, env, site = _install(wheel, option, tmp_path / "install")
    run = tmp_path / "run"
    run.mkdir()
    where = subprocess.run([python, "-c", "import odms_data; print(odms_data.__file__)"], cwd=run,
                           env=env, capture_output=True, text=True, check=True).stdout
    assert Path(where.strip()).is_relative_to(site)
    assert not (site / "schemas").exists()  # shipped inside the package, not beside it
    generate = ["generate", "--split", "sim-val", "-o", "v.zarr", "--workers", workers]
    out = subprocess.run([python, "-m", "odms_data.cli", *generate], cwd=run, env=env,
                         capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
    assert "digest matches splits/sim-val.json" in out.stdout


def test_the_wheel_carries_the_mit_licence(wheel):
    """setup.cfg says MIT: the licence's text ships in the wheel's metadata."""
    import zipfile

    with zipfile.ZipFile(wheel) as z:
        (name,) = [n for n in z.namelist() if n.endswith("LICENSE") and ".dist-info/" in n]
        text = z.read(name).decode()
    assert text.startswith("MIT License") and "WITHOUT WARRANTY OF ANY KIND" in text
