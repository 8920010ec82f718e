"""The URL owner (odms_data/urls.py): which schemes each place accepts, one line for a missing
package, and no URL ever written as a local path; run as users run the command."""

from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

import pytest
from owner_ast import imported, nodes_outside

from odms_data.simulate.generate_store import generate
from odms_data.simulate.params import GeneratorParams

PARAMS = GeneratorParams(image_size=(48, 64), sizes=(10, 20))
WITHOUT = "import sys\nfor m in {missing!r}: sys.modules[m] = None  # as if not installed\n"
RUN = "from odms_data.cli import main\nsys.argv[0] = 'odms-data'\nmain()\n"


def odms(cwd: Path, *args: str, missing: tuple[str, ...] = ()) -> subprocess.CompletedProcess:
    """The command, in a process where the packages `missing` cannot be imported."""
    return subprocess.run([sys.executable, "-c", WITHOUT.format(missing=missing) + RUN, *args], cwd=cwd,
                          capture_output=True, text=True, timeout=300)


def one_line(r: subprocess.CompletedProcess, *words: str) -> None:
    assert r.returncode == 2, r.stderr
    assert r.stderr.startswith("odms-data: error: ") and r.stderr.count("\n") == 1, r.stderr
    assert all(w in r.stderr for w in words), r.stderr


@pytest.fixture(scope="module")
def store(tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("urls") / "tiny-val.zarr"
    generate(str(path), 4, PARAMS, 3, split="tiny-val", workers=1)
    return path


def test_a_command_refuses_a_store_that_lives_in_one_process(tmp_path, store):
    """generate said it wrote a memory:// store that vanished with it; export exited 3."""
    one_line(odms(tmp_path, "generate", "-n", "2", "-o", "memory://g.zarr"), "memory://g.zarr", "vanishes")
    one_line(odms(tmp_path, "export", str(store), "-o", "memory://hub"), "memory://hub")
    one_line(odms(tmp_path, "info", "--json", "memory://x.zarr"), "memory://x.zarr")
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("missing", [(), ("s3fs",)], ids=["with-s3fs", "without-s3fs"])
def test_a_local_output_named_as_a_url_is_refused_not_written_as_folders(tmp_path, store, missing):
    """baseline -o s3://b/v.csv wrote ./s3:/b/v.csv and said it wrote to S3."""
    r = odms(tmp_path, "baseline", "vosde", str(store), "-o", "s3://b/v.csv", missing=missing)
    one_line(r, "s3://b/v.csv", "a URL", "local path")
    one_line(odms(tmp_path, "export", str(store), "-o", "s3://b/hub", missing=missing), "s3:/b/hub", "a URL")
    assert list(tmp_path.iterdir()) == []


def test_schemes_odms_data_does_not_read_are_one_line(tmp_path, store):
    """info http://... and score --data ssh://... exited 3 on a missing optional package."""
    one_line(odms(tmp_path, "info", "http://example.invalid/x.zarr"), "not at http://")
    (tmp_path / "p.csv").write_text("split,id,d1\n")
    one_line(odms(tmp_path, "score", "p.csv", "--data", "ssh://host/x.zarr"), "not at ssh://")


def test_a_scheme_whose_package_is_missing_names_its_extra(tmp_path):
    one_line(odms(tmp_path, "info", "s3://bucket/x.zarr", missing=("s3fs",)), "s3fs", "odms-data[s3]")
    one_line(odms(tmp_path, "generate", "-n", "2", "-o", "gs://bucket/x.zarr", missing=("gcsfs",)),
             "gcsfs", "odms-data[gcs]")


FSSPEC_PACKAGES = ("fsspec", "s3fs", "gcsfs", "adlfs")


def test_no_module_but_urls_opens_a_url_or_decides_a_scheme():
    """fsspec and its filesystems are imported, and a path tested for a scheme ('://' in a
    comparison or a startswith), only in odms_data/urls.py."""
    found = []
    for name, node in nodes_outside("urls.py"):
        found += [f"{name}: import {n}" for n in imported(node) if n.split(".")[0] in FSSPEC_PACKAGES]
        starts = isinstance(node, ast.Call) and getattr(node.func, "attr", "") == "startswith"
        tested = [*node.comparators, node.left] if isinstance(node, ast.Compare) else \
            node.args if starts else []
        found += [f"{name}: {c.value!r}" for c in tested
                  if isinstance(c, ast.Constant) and isinstance(c.value, str) and "://" in c.value]
    assert found == []


NO_CREDENTIALS = {"AWS_ACCESS_KEY_ID": "", "AWS_SECRET_ACCESS_KEY": "",
                  "AWS_SHARED_CREDENTIALS_FILE": "/nonexistent", "AWS_CONFIG_FILE": "/nonexistent",
                  "AWS_EC2_METADATA_DISABLED": "true"}


def test_an_object_store_without_credentials_is_one_line_naming_the_url(tmp_path, store, monkeypatch):
    """s3:// without credentials exited 3 (botocore's NoCredentialsError) in every command."""
    for k, v in NO_CREDENTIALS.items():
        monkeypatch.setenv(k, v) if v else monkeypatch.delenv(k, raising=False)
    one_line(odms(tmp_path, "info", "s3://bucket/x.zarr"), "s3://bucket/x.zarr", "cannot be reached",
             "credentials")
    one_line(odms(tmp_path, "generate", "-n", "2", "-o", "s3://bucket/g.zarr"), "s3://bucket/g.zarr",
             "cannot be reached")
    one_line(odms(tmp_path, "convert", str(store), "s3://bucket/t.h5"), "s3://bucket/t.h5",
             "cannot be reached")
    assert list(tmp_path.iterdir()) == []


def test_only_a_place_is_refused_as_a_memory_store_not_a_text(tmp_path, store):
    """The refusal of memory:// took every argument: a --name holding the text was refused too."""
    import shutil

    shutil.copytree(store, tmp_path / "tiny-val.zarr")
    (tmp_path / "p.csv").write_text("split,example_id,d1\n" + "".join(
        f"tiny-val,tiny-val/{i:06d},0.5\n" for i in range(4)))
    r = odms(tmp_path, "score", "p.csv", "--data", "tiny-val.zarr", "--name", "memory://x",
             "--entry", "e.json")
    assert "lives only in the process" not in r.stderr and "no official split" in r.stderr, r.stderr
    one_line(odms(tmp_path, "score", "p.csv", "--data=memory://x"), "memory://x", "vanishes")
    one_line(odms(tmp_path, "leaderboard", "verify", "--dir", "memory://x"), "memory://x", "vanishes")


def test_a_training_run_named_as_a_url_leaves_no_folder(tmp_path, store):
    """train -o s3://bucket/x made ./s3:/bucket/x before it refused the URL."""
    one_line(odms(tmp_path, "train", "-o", "s3://bucket/x", "--val", str(store), "--iterations", "1"),
             "s3://bucket/x", "a URL")
    assert list(tmp_path.iterdir()) == []
