"""The restricted reader of pickles and checkpoints: what NumPy and torch write comes back, within
bounds; nothing else runs."""

from __future__ import annotations

import ast
import pickle
import subprocess
import sys
import zipfile
from pathlib import Path

import numpy as np
import pytest
import torch
from owner_ast import imported, nodes_outside

from odms_data import pickles
from odms_data.errors import InputError
from odms_data.pickles import load_checkpoint, load_pickle


def _write(tmp_path, data: bytes, name="set.pk"):
    p = tmp_path / name
    p.write_bytes(data)
    return p


def test_an_odmd_like_set_comes_back_equal(tmp_path):
    rng = np.random.default_rng(0)
    arrays = {"bboxes": rng.uniform(size=(10, 5, 7)), "move": rng.normal(size=(9, 3, 7)),
              "ints": np.arange(7, dtype=np.int32), "bools": np.ones(7, np.uint8) > 0,
              "fortran": np.asfortranarray(rng.normal(size=(3, 4)))}
    obj = {"test_name": "val", "bb": {"image_dim": [480, 640], "fx_norm": 0.32, "n_ex": 7, **arrays}}
    got = load_pickle(_write(tmp_path, pickle.dumps(obj, protocol=3)))
    assert got["bb"]["image_dim"] == [480, 640] and got["bb"]["fx_norm"] == 0.32 and got["test_name"] == "val"
    for name, b in arrays.items():
        a = got["bb"][name]
        assert a.dtype == b.dtype and np.array_equal(a, b)


class _Runs:
    def __reduce__(self):
        import os

        return (os.system, ("touch pwned",))


def test_a_pickle_that_would_run_a_command_is_refused(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    p = _write(tmp_path, pickle.dumps({"bb": _Runs()}, protocol=3))
    with pytest.raises(InputError, match=r"set\.pk: refused: it names (posix|os)\.system"):
        load_pickle(p)
    assert not (tmp_path / "pwned").exists()


@pytest.mark.parametrize("obj", [{1, 2}, bytearray(b"x"), complex(1, 2), np.float64(3.0)])
def test_unknown_types_are_refused_in_one_line(tmp_path, obj):
    with pytest.raises(InputError) as e:
        load_pickle(_write(tmp_path, pickle.dumps({"x": obj}, protocol=3)))
    assert "refused" in str(e.value) and "\n" not in str(e.value)


class _DeclaredArray:
    """Pickles as NumPy pickles an array, with whatever shape and bytes it is given."""

    def __init__(self, shape: tuple, payload: bytes) -> None:
        self.shape, self.payload = shape, payload

    def __reduce__(self):
        from numpy._core.multiarray import _reconstruct

        return _reconstruct, (np.ndarray, (0,), b"b"), (1, self.shape, np.dtype("f8"), False, self.payload)


def _array_pickle(shape: tuple, payload: bytes) -> bytes:
    return pickle.dumps({"a": _DeclaredArray(shape, payload)}, protocol=3)


def test_a_huge_declared_array_is_refused_before_allocating(tmp_path):
    data = _array_pickle((2**20, 2**20), b"\0" * 16)
    with pytest.raises(InputError, match=r"declares 1099511627776 elements"):
        load_pickle(_write(tmp_path, data))


def test_an_array_whose_bytes_disagree_with_its_shape_is_refused(tmp_path):
    data = _array_pickle((3,), b"\0" * 16)
    with pytest.raises(InputError, match=r"carries 16 bytes, not 24"):
        load_pickle(_write(tmp_path, data))


def test_an_object_dtype_is_refused(tmp_path):
    data = pickle.dumps(np.array([1, "a"], dtype=object), protocol=3)
    with pytest.raises(InputError, match="refused: dtype 'O8' is not a plain numeric type"):
        load_pickle(_write(tmp_path, data))


def test_a_huge_declared_byte_string_reads_nothing_beyond_the_file(tmp_path):
    data = b"\x80\x03B" + (2**31 - 1).to_bytes(4, "little") + b"abc."
    with pytest.raises(InputError, match=r"not a readable ODMD pickle"):
        load_pickle(_write(tmp_path, data))


def test_a_huge_memo_index_allocates_nothing(tmp_path):
    data = b"\x80\x03K\x01r\xff\xff\xff\xff."  # LONG_BINPUT 2**32 - 1
    assert load_pickle(_write(tmp_path, data)) == 1


def test_files_beyond_the_bound_are_not_read(tmp_path, monkeypatch):
    monkeypatch.setattr(pickles, "MAX_FILE_BYTES", 100)
    with pytest.raises(InputError, match=r"larger than 100 bytes"):
        load_pickle(_write(tmp_path, pickle.dumps(list(range(100)), protocol=3)))


@pytest.mark.parametrize("data", [b"", b"\x80\x03", b"not a pickle", b"\x80\x03}q\x00(X\x01"])
def test_truncated_or_foreign_bytes_are_one_line_errors(tmp_path, data):
    with pytest.raises(InputError) as e:
        load_pickle(_write(tmp_path, data))
    assert str(e.value).startswith(str(tmp_path / "set.pk")) and "\n" not in str(e.value)


def test_deep_nesting_is_refused(tmp_path):
    obj: list = []
    for _ in range(100):
        obj = [obj]
    with pytest.raises(InputError, match="nests deeper than 32"):
        load_pickle(_write(tmp_path, pickle.dumps(obj, protocol=3)))


def test_shared_sub_lists_count_each_time_they_are_reached(tmp_path):
    """A few hundred bytes whose memo shares each level's list 8 times: 8^7 elements once expanded."""
    obj: list = [0] * 8
    for _ in range(6):
        obj = [obj] * 8
    data = pickle.dumps(obj, protocol=3)
    assert len(data) < 600
    with pytest.raises(InputError, match=r"reaches more than 1048576 elements"):
        load_pickle(_write(tmp_path, data))


def test_a_dict_key_nested_a_million_deep_is_refused_before_it_is_hashed(tmp_path):
    """Hashing the key recursed in C and killed the process (SIGSEGV): run apart, to survive it."""
    key = b"K\x00" + b"\x85" * 1_000_000  # BININT1 0, then TUPLE1 a million times
    path = _write(tmp_path, b"\x80\x03}" + key + b"K\x01s.")  # EMPTY_DICT, key, value, SETITEM
    r = subprocess.run([sys.executable, "-c", f"from odms_data.pickles import load_pickle\n"
                        f"load_pickle({str(path)!r})"], capture_output=True, text=True, timeout=120)
    assert r.returncode == 1 and "refused: it nests deeper than 32 levels" in r.stderr, r.stderr[-300:]


def test_a_value_that_contains_itself_is_refused(tmp_path):
    obj: list = []
    obj.append(obj)
    with pytest.raises(InputError, match="contains itself"):
        load_pickle(_write(tmp_path, pickle.dumps(obj, protocol=3)))


# -- checkpoints


def _deflate_storages(src: Path, dst: Path) -> None:
    with zipfile.ZipFile(src) as a, zipfile.ZipFile(dst, "w") as b:
        for info in a.infolist():
            packed = "/data/" in info.filename
            b.writestr(info.filename, a.read(info), zipfile.ZIP_DEFLATED if packed else zipfile.ZIP_STORED)


def test_checkpoints_torch_writes_come_back(tmp_path):
    saved = {"iteration": 3, "model": {"w": torch.randn(4, 5), "b": torch.zeros(5, dtype=torch.float64)},
             "rng": torch.get_rng_state(), "best_per_set": {"v": (1.5, 2)}, "seconds": 0.5}
    torch.save(saved, tmp_path / "c.pt")
    got = load_checkpoint(tmp_path / "c.pt")
    assert got["iteration"] == 3 and got["best_per_set"] == {"v": (1.5, 2)}
    assert torch.equal(got["model"]["w"], saved["model"]["w"]) and torch.equal(got["rng"], saved["rng"])


def test_a_compressed_record_is_refused_before_it_is_inflated(tmp_path):
    """A storage record deflated: 1 MiB of zeros on disk declares 64 MiB once inflated."""
    torch.save({"w": torch.zeros(16 << 20)}, tmp_path / "plain.pt")
    _deflate_storages(tmp_path / "plain.pt", tmp_path / "packed.pt")
    assert (tmp_path / "packed.pt").stat().st_size < 1 << 20
    with pytest.raises(InputError, match=r"packed.pt: refused: .*data/0 is compressed"):
        load_checkpoint(tmp_path / "packed.pt")


@pytest.mark.parametrize("tensor", [
    lambda: torch.sparse_coo_tensor([[0, 1], [1, 0]], [1.0, 2.0], (2, 2), check_invariants=True),
    lambda: torch.ones(2, 2).to_sparse_csr(),
    lambda: torch._make_per_tensor_quantized_tensor(torch.ones(4, dtype=torch.uint8), 0.1, 0),
    lambda: torch.ones(3, dtype=torch.complex64),
], ids=["sparse", "sparse-csr", "quantised", "complex"])
@pytest.mark.filterwarnings("ignore:torch.quantize_per_tensor")  # torch's deprecation of making them
def test_layouts_and_dtypes_the_models_never_hold_are_refused(tmp_path, tensor):
    torch.save({"w": tensor()}, tmp_path / "c.pt")
    with pytest.raises(InputError, match=r"c.pt: refused: it names torch"):
        load_checkpoint(tmp_path / "c.pt")


def test_a_tensor_viewing_more_than_its_storage_is_refused(tmp_path):
    torch.save({"w": torch.ones(1).expand(1 << 20)}, tmp_path / "c.pt")  # a stride-0 view of 1 element
    with pytest.raises(InputError, match=r"views beyond its storage of 1 elements"):
        load_checkpoint(tmp_path / "c.pt")


def test_a_storage_larger_than_its_record_is_refused(tmp_path):
    torch.save({"w": torch.ones(8)}, tmp_path / "c.pt")
    with zipfile.ZipFile(tmp_path / "c.pt") as a, zipfile.ZipFile(tmp_path / "d.pt", "w") as b:
        for info in a.infolist():
            b.writestr(info.filename, a.read(info)[:16] if info.filename.endswith("data/0") else a.read(info))
    with pytest.raises(InputError, match=r"declares 8 elements, its record holds 16 bytes"):
        load_checkpoint(tmp_path / "d.pt")


def test_a_run_checkpoint_is_bounded_as_a_given_one(tmp_path):
    """best.pt had no size bound (read_checkpoint read any size)."""
    from odms_data.network.runtime import read_checkpoint

    big = tmp_path / "best.pt"
    with open(big, "wb") as f:
        f.truncate(pickles.MAX_CHECKPOINT_BYTES + 1)
    with pytest.raises(InputError, match=r"best.pt: larger than 64 MiB, not a checkpoint"):
        read_checkpoint(big)


def test_the_legacy_stream_must_add_up(tmp_path, odmd_pretrained):
    data = odmd_pretrained.read_bytes()
    assert len(load_checkpoint(odmd_pretrained)) == 18  # the authors' DBox, in torch's legacy format
    _write(tmp_path, data + b"\0", "more.pt")
    with pytest.raises(InputError, match=r"more.pt: refused: its storages declare"):
        load_checkpoint(tmp_path / "more.pt")


UNTRUSTED_READS = ("pickle", "pickletools", "marshal", "shelve", "dill", "cloudpickle", "joblib", "zipfile")


def test_no_module_but_pickles_reads_a_pickle_or_checkpoint():
    """pickle and its kin are imported, and torch.load / np.load called, only in odms_data/pickles.py."""
    found = []
    for name, node in nodes_outside("pickles.py"):
        found += [f"{name}: import {n}" for n in imported(node) if n.split(".")[0] in UNTRUSTED_READS]
        if (isinstance(node, ast.Attribute) and node.attr in ("load", "load_state_dict_from_url")
                and isinstance(node.value, ast.Name) and node.value.id in ("torch", "np", "numpy")):
            found.append(f"{name}: {node.value.id}.{node.attr}")
    assert found == []
