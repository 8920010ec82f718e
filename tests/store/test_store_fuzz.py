"""Fuzzing the store reader: any bytes where a store's metadata or data should be either read
correctly or are refused with the project's own StoreError, never another exception."""

import json
import re
import shutil
from pathlib import Path

import pytest
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

from odms_data.errors import OdmsError
from odms_data.simulate.generate_store import generate
from odms_data.simulate.params import PRESETS
from odms_data.store.reader import open_store
from odms_data.store.validate import validate

FUZZ = settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])


@pytest.fixture(scope="module")
def stores(tmp_path_factory) -> dict[str, Path]:
    root = tmp_path_factory.mktemp("fuzz")
    out = {}
    for name in ("s.zarr", "s.h5"):
        generate(str(root / name), 4, PRESETS["perturb"], 1, split="fuzz")
        out[name] = root / name
    return out


def read_everything(path: Path) -> None:
    """Open and read a store fully; must succeed or raise OdmsError."""
    try:
        with open_store(str(path)) as s:
            for i in range(s.n_examples):
                s.example(i)
    except OdmsError:
        pass
    report = validate(str(path))  # never raises
    assert report.ok or report.problems


json_values = st.recursive(
    st.none() | st.booleans() | st.integers() | st.floats(allow_nan=False) | st.text(max_size=8),
    lambda kids: st.lists(kids, max_size=4) | st.dictionaries(st.text(max_size=8), kids, max_size=4),
    max_leaves=12,
)


@FUZZ
@given(data=st.binary(max_size=300))
def test_random_bytes_as_root_metadata(stores, tmp_path_factory, data):
    path = tmp_path_factory.mktemp("f") / "s.zarr"
    shutil.copytree(stores["s.zarr"], path)
    (path / "zarr.json").write_bytes(data)
    read_everything(path)


@FUZZ
@given(value=json_values, key=st.sampled_from(["odms", "split", "image_size", "counts", "digest"]))
def test_random_json_in_the_attributes(stores, tmp_path_factory, value, key):
    path = tmp_path_factory.mktemp("f") / "s.zarr"
    shutil.copytree(stores["s.zarr"], path)
    meta = json.loads((path / "zarr.json").read_text())
    if key == "odms":
        meta["attributes"]["odms"] = value
    else:
        meta["attributes"]["odms"][key] = value
    (path / "zarr.json").write_text(json.dumps(meta))
    read_everything(path)


@FUZZ
@given(data=st.binary(max_size=300), array=st.sampled_from(["masks", "z", "frame_index", "example_id"]))
def test_random_bytes_as_array_metadata(stores, tmp_path_factory, data, array):
    path = tmp_path_factory.mktemp("f") / "s.zarr"
    shutil.copytree(stores["s.zarr"], path)
    (path / array / "zarr.json").write_bytes(data)
    read_everything(path)


@FUZZ
@given(offset=st.integers(min_value=0), data=st.binary(min_size=1, max_size=64))
@example(offset=38_434_758_830, data=b"\x00" * 5)  # once made frame_index read back empty
@example(offset=4096, data=b"\x00")  # once made an HDF5 name resolve to a non-dataset
def test_random_bytes_written_into_a_shard_or_hdf5_file(stores, tmp_path_factory, offset, data):
    root = tmp_path_factory.mktemp("f")
    shutil.copytree(stores["s.zarr"], root / "s.zarr")
    shutil.copy(stores["s.h5"], root / "s.h5")
    for target in (root / "s.zarr" / "masks" / "c" / "0" / "0" / "0", root / "s.h5"):
        raw = bytearray(target.read_bytes())
        at = offset % len(raw)
        raw[at : at + len(data)] = data
        target.write_bytes(bytes(raw))
    read_everything(root / "s.zarr")
    read_everything(root / "s.h5")


@FUZZ
@given(data=st.binary(max_size=2000))
def test_random_bytes_as_a_whole_hdf5_file(tmp_path_factory, data):
    path = tmp_path_factory.mktemp("f") / "s.h5"
    path.write_bytes(b"\x89HDF\r\n\x1a\n" + data)
    read_everything(path)


# the signatures that start HDF5's metadata blocks (B-trees, heaps, symbol tables, object headers, ...)
HDF5_BLOCKS = re.compile(rb"TREE|HEAP|SNOD|GCOL|OHDR|OCHK|BTHD|BTIN|BTLF|FRHP|FHDB|FHIB|FSHD|FSSE"
                         rb"|EAHD|EAIB|EADB|FAHD|FADB")


def test_each_hdf5_metadata_block_damaged_in_turn(stores, tmp_path):
    """libhdf5 raises RuntimeError, OSError, KeyError, ... on damaged metadata (a chunk B-tree's
    signature: 'Can't get number of chunks'); each is a StoreError or a problem of validate's."""
    raw = stores["s.h5"].read_bytes()
    blocks = [m.start() for m in HDF5_BLOCKS.finditer(raw)]
    assert sum(raw[b:b + 4] == b"TREE" for b in blocks) >= 8  # a chunk index for each array at least
    for at in blocks:
        damaged = bytearray(raw)
        damaged[at] ^= 0xFF
        path = tmp_path / f"at-{at}.h5"
        path.write_bytes(bytes(damaged))
        read_everything(path)
