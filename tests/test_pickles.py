"""The restricted reader of ODMD's pickles: what NumPy writes comes back; nothing else runs."""

from __future__ import annotations

import pickle

import numpy as np
import pytest

from odms_data import pickles
from odms_data.errors import InputError
from odms_data.pickles import load_pickle


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
    with pytest.raises(InputError, match=r"larger than 0 MiB"):
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
