"""One contract for every way a store is kept and read: Zarr read through zarr, Zarr read by the
fast shard reader, and HDF5. Each backend runs the same tests (as zarr-python's
testing/store.py gives every store implementation the same suite)."""

from __future__ import annotations

import pickle
import shutil
from pathlib import Path

import numpy as np
import pytest
from _stores import stats_of

from odms_data.errors import StoreError, StoreExistsError
from odms_data.store.digest import recompute_digest
from odms_data.store.format import StoreAttrs
from odms_data.store.masks import pack
from odms_data.store.reader import Store, open_store
from odms_data.store.writer import Layout, StoreWriter

H, W = 24, 37  # a width that is not a multiple of 8
FRAMES, EXAMPLES = 23, 7


def content() -> dict:
    """Masks, positions and examples of a small store, different in every frame."""
    rng = np.random.default_rng(11)
    masks = rng.random((FRAMES, H, W)) < np.linspace(0.05, 0.6, FRAMES)[:, None, None]
    masks[4] = False  # an empty mask
    z = np.cumsum(rng.uniform(0.01, 0.1, FRAMES))
    depth = z + 0.5
    depth[6] = np.nan
    frame_index = np.full((EXAMPLES, 5), -1, np.int64)
    for e in range(EXAMPLES):
        n = 2 + e % 4
        frame_index[e, :n] = 3 * e + np.arange(n)
    d1 = depth[frame_index[:, 0]].copy()
    d1[2] = np.nan
    ids = [f"contract/{e:03d}" + "é" * (e % 2) for e in range(EXAMPLES)]
    return {"masks": masks, "z": z, "depth": depth, "frame_index": frame_index, "d1": d1, "ids": ids,
            "sources": [f"src{e}" for e in range(EXAMPLES)]}


def write(path: Path, fmt: str, c: dict, *, overwrite: bool = False, workers: bool = False) -> None:
    """The store of `c`; `workers`: its masks written shard by shard through the writer's sink, as
    generate's and the importers' workers write them."""
    layout = Layout(height=H, width=W, n_frames=FRAMES, n_examples=EXAMPLES, max_obs=5, id_width=20,
                    source_width=8, frames_per_chunk=3, frames_per_shard=9, examples_per_chunk=4)
    attrs = StoreAttrs(split="contract", domain="recording", image_size=(H, W),
                       counts={"examples": EXAMPLES, "frames": FRAMES,
                               "labelled": int(np.isfinite(c["d1"]).sum())},
                       source="the contract tests", digest="sha256:" + "0" * 64)
    with StoreWriter(str(path), fmt, overwrite=overwrite) as w:
        w.create(layout)
        if workers:
            sink, packed = pickle.loads(pickle.dumps(w.mask_sink())), pack(c["masks"])  # as tasks carry it
            shard = layout.frames_per_shard
            for start in range(0, FRAMES, shard):
                w.receive_masks(start, sink.write_packed(start, packed[start : start + shard]))
        else:
            w.write_masks(0, pack(c["masks"]))
        w.write_rows("frame", 0, {"z": c["z"], "depth": c["depth"], **vars(stats_of(c["masks"]))})
        w.write_rows("example", 0, {"frame_index": c["frame_index"], "d1": c["d1"], "example_id": c["ids"],
                                    "source": c["sources"]})
        w.commit(attrs)


class StoreContract:
    """The tests; a subclass names the backend (`fmt`) and how its stores are opened."""

    fmt: str
    suffix: str

    def open(self, path: Path) -> Store:
        return open_store(str(path))

    @pytest.fixture
    def written(self, tmp_path) -> tuple[Path, dict]:
        c = content()
        path = tmp_path / f"s{self.suffix}"
        write(path, self.fmt, c)
        return path, c

    def test_reads_back_what_was_written(self, written):
        path, c = written
        with self.open(path) as s:
            assert (s.format, s.n_frames, s.n_examples) == (self.fmt, FRAMES, EXAMPLES)
            assert (s.height, s.width) == (H, W)
            np.testing.assert_array_equal(s.read_masks(np.arange(FRAMES)), c["masks"])
            np.testing.assert_array_equal(s.z, c["z"])
            np.testing.assert_array_equal(s.depth, c["depth"])
            np.testing.assert_array_equal(s.frame_index, c["frame_index"])
            np.testing.assert_array_equal(s.d1, c["d1"])
            assert (s.example_ids, s.sources) == (c["ids"], c["sources"])
            stats = stats_of(c["masks"])
            np.testing.assert_array_equal(s.area, stats.area)
            np.testing.assert_array_equal(s.largest_area, stats.largest_area)
            np.testing.assert_array_equal(s.bbox, stats.bbox)

    def test_any_range_and_any_frames(self, written):
        path, c = written
        packed = pack(c["masks"])
        rng = np.random.default_rng(2)
        with self.open(path) as s:
            for lo, hi in [(0, 1), (2, 3), (8, 10), (0, FRAMES), (17, FRAMES + 4), (5, 5)]:
                np.testing.assert_array_equal(s.read_packed(lo, hi), packed[lo:hi])
            for frames in ([22, 0, 9], rng.permutation(FRAMES)[:11], [4, 4]):
                np.testing.assert_array_equal(s.read_masks(np.array(frames)), c["masks"][frames])

    def test_examples_by_row_and_by_id(self, written):
        path, c = written
        with self.open(path) as s:
            for e in range(EXAMPLES):
                ex = s.example(c["ids"][e])
                rows = c["frame_index"][e][c["frame_index"][e] >= 0]
                np.testing.assert_array_equal(ex.masks, c["masks"][rows])
                assert ex.n == len(rows) and s.example(e).example_id == c["ids"][e]

    def test_digest_does_not_depend_on_the_backend(self, written, tmp_path):
        path, c = written
        other = tmp_path / ("o.h5" if self.fmt == "zarr" else "o.zarr")
        write(other, "hdf5" if self.fmt == "zarr" else "zarr", c)
        with self.open(path) as s, open_store(str(other)) as o:
            assert recompute_digest(s)[0] == recompute_digest(o)[0]

    def test_masks_written_by_workers_through_the_sink_read_back_the_same(self, written, tmp_path):
        path, c = written
        other = tmp_path / f"w{self.suffix}"
        write(other, self.fmt, c, workers=True)
        with self.open(path) as s, self.open(other) as o:
            np.testing.assert_array_equal(o.read_masks(np.arange(FRAMES)), c["masks"])
            assert recompute_digest(o)[0] == recompute_digest(s)[0]

    def test_an_existing_store_is_kept_without_overwrite(self, written):
        path, c = written
        before = sorted(p.name for p in path.parent.iterdir())
        with pytest.raises(StoreExistsError):
            write(path, self.fmt, c)
        assert sorted(p.name for p in path.parent.iterdir()) == before
        write(path, self.fmt, c, overwrite=True)
        with self.open(path) as s:
            np.testing.assert_array_equal(s.d1, c["d1"])

    def test_an_incomplete_store_is_refused(self, tmp_path):
        c = content()
        path = tmp_path / f"i{self.suffix}"
        with pytest.raises(RuntimeError), StoreWriter(str(path), self.fmt) as w:
            w.create(Layout(height=H, width=W, n_frames=FRAMES, n_examples=EXAMPLES, max_obs=5, id_width=20,
                            source_width=8, frames_per_chunk=3, frames_per_shard=9, examples_per_chunk=4))
            w.write_masks(0, pack(c["masks"]))
            raise RuntimeError("interrupted")
        assert not path.exists() and not Path(f"{path}.partial").exists()

    def test_a_damaged_mask_chunk_is_a_store_error(self, written, tmp_path):
        path, _ = written
        damaged = tmp_path / f"d{self.suffix}"
        if path.is_dir():
            shutil.copytree(path, damaged)
            shard = damaged / "masks" / "c" / "1" / "0" / "0"
            data = bytearray(shard.read_bytes())
            data[len(data) // 3] ^= 0xFF  # inside a compressed chunk
            shard.write_bytes(bytes(data))
        else:
            data = bytearray(path.read_bytes())
            with self.open(path) as s:
                chunk = s.backend.array("masks").dset.id.get_chunk_info(3)  # frames 9..11
            data[chunk.byte_offset + chunk.size // 2] ^= 0xFF
            damaged.write_bytes(bytes(data))
        with self.open(damaged) as s, pytest.raises(StoreError):
            s.read_packed(9, 18)


class TestZarrThroughZarr(StoreContract):
    fmt, suffix = "zarr", ".zarr"

    def open(self, path: Path) -> Store:
        store = open_store(str(path))
        store._fast = None  # read every mask through zarr's own API
        return store


class TestZarrThroughShardReader(StoreContract):
    fmt, suffix = "zarr", ".zarr"

    def open(self, path: Path) -> Store:
        store = open_store(str(path))
        assert store._fast is not None, "the fast shard reader should serve stores StoreWriter makes"
        return store


class TestHdf5(StoreContract):
    fmt, suffix = "hdf5", ".h5"
