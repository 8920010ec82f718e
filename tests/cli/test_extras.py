"""A command or loader whose extra is not installed says in one line which extra to install (exit 2):
the real command line, run with the extra's modules hidden from the import system."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from odms_data.simulate.generate_store import generate
from odms_data.simulate.params import GeneratorParams

HIDE = """
import sys
hidden = set(sys.argv.pop(1).split(","))
class Hide:  # finds every hidden module first, and says it is not installed
    def find_spec(self, name, path=None, target=None):
        if name.split(".")[0] in hidden:
            raise ModuleNotFoundError(f"No module named {name!r}", name=name)
sys.meta_path.insert(0, Hide())
"""
CLI = HIDE + "from odms_data.cli import main\nsys.argv[0] = 'odms-data'\nmain()\n"
LIBRARY = HIDE + "import importlib\nimportlib.import_module(sys.argv[1])\n"


def without(hidden: str, *args: str, program: str = CLI) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-c", program, hidden, *args], capture_output=True, text=True)


def assert_names_extra(r: subprocess.CompletedProcess, extra: str, *fragments: str) -> None:
    lines = r.stderr.strip().splitlines()
    assert r.returncode == 2 and len(lines) == 1 and lines[0].startswith("odms-data: error: "), r.stderr
    for f in (f"pip install 'odms-data[{extra}]'", f"pip install '.[{extra}]'", *fragments):
        assert f in lines[0], lines[0]


@pytest.fixture(scope="module")
def store(tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("extras") / "tiny-val.zarr"
    generate(str(path), 2, GeneratorParams(image_size=(60, 80), sizes=(20,)), seed=3, split="tiny-val",
             workers=1)
    return path


def test_train_and_predict_without_torch(tmp_path, store):
    run = tmp_path / "run"
    r = without("torch", "train", "-o", str(run), "--val", str(store), "--iterations", "1")
    assert_names_extra(r, "torch", "odms-data train needs torch")
    assert not run.exists()
    r = without("torch", "predict", str(run), "--data", str(store), "-o", str(tmp_path / "p.csv"))
    assert_names_extra(r, "torch", "odms-data predict needs torch")
    assert not (tmp_path / "p.csv").exists()


def test_score_plot_without_matplotlib(tmp_path, store):
    preds = tmp_path / "p.csv"
    preds.write_text("example_id,d1\ntiny-val/000000,1.0\ntiny-val/000001,1.0\n")
    r = without("matplotlib", "score", str(preds), "--data", str(store), "--plot", str(tmp_path / "e.png"))
    assert_names_extra(r, "plot", "odms-data score --plot needs matplotlib")
    assert not (tmp_path / "e.png").exists()


def test_export_without_pyarrow(tmp_path, store):
    r = without("pyarrow", "export", str(store), "-o", str(tmp_path / "hub"))
    assert_names_extra(r, "hub", "odms-data export needs pyarrow")
    assert not (tmp_path / "hub").exists()


def test_generate_on_a_cluster_without_dask(tmp_path):
    out = tmp_path / "x.zarr"
    r = without("distributed,dask", "generate", "-n", "2", "--scheduler", "tcp://127.0.0.1:9", "-o", str(out))
    assert_names_extra(r, "dask", "--scheduler needs distributed")
    assert not out.exists() and not list(tmp_path.iterdir())


@pytest.mark.parametrize("module,hidden,extra", [
    ("odms_data.loaders.torch_loader", "torch", "torch"),
    ("odms_data.simulate.torch_render", "torch", "torch"),
    ("odms_data.loaders.tf_loader", "tensorflow", "tf"),
    ("odms_data.loaders.grain_loader", "grain", "jax"),
])
def test_loaders_without_their_framework(module, hidden, extra):
    program = LIBRARY.replace("importlib.import_module(sys.argv[1])", """try:
    importlib.import_module(sys.argv[1])
except ImportError as e:
    from odms_data.errors import MissingExtraError
    print(type(e).__name__, isinstance(e, MissingExtraError), e, file=sys.stderr)
    sys.exit(2)""")
    r = without(hidden, module, program=program)
    assert r.returncode == 2, r.stderr
    assert r.stderr.startswith("MissingExtraError True ") and f"{module} needs {hidden}" in r.stderr
    assert f"pip install 'odms-data[{extra}]'" in r.stderr


def test_a_missing_module_of_no_extra_is_not_called_an_extra():
    program = LIBRARY.replace("importlib.import_module(sys.argv[1])", """from odms_data.extras import optional
try:
    optional(sys.argv[1], "this test")
except ImportError as e:
    print(type(e).__name__, e.name, file=sys.stderr)""")
    r = without("cv2", "cv2", program=program)
    assert r.stderr.strip() == "ModuleNotFoundError cv2", r.stderr


def test_generate_config_without_pyyaml(tmp_path):
    config = tmp_path / "rotation.yaml"
    config.write_text("rotation: 2\n")
    out = tmp_path / "boxes.zarr"
    r = without("yaml", "generate", "-n", "3", "--boxes", "odmd", "--config", str(config), "-o", str(out))
    assert_names_extra(r, "yaml", "odms-data generate --config needs yaml")
    assert not out.exists()
