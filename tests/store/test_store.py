"""Stores: generation into Zarr and HDF5, determinism, conversion, validation of corruption."""

import json
import re
import shutil
import threading
import warnings
from pathlib import Path

import numpy as np
import pytest
import zarr
from _stores import stats_of

from odms_data.errors import InputError, StoreError, StoreExistsError, StoreLockedError
from odms_data.simulate.generate_store import generate
from odms_data.simulate.object_model import sample_example
from odms_data.simulate.params import GENERATOR_VERSION, PRESETS, preset
from odms_data.simulate.render import reference_masks
from odms_data.store.convert import convert
from odms_data.store.digest import frame_digests, frame_tails, padded_frame_digests
from odms_data.store.masks import mask_stats, pack, packed_stats, unpack
from odms_data.store.reader import open_store
from odms_data.store.validate import validate
from odms_data.store.writer import StoreWriter

PERTURB = PRESETS["perturb"]


@pytest.fixture(scope="module")
def small_zarr(tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("s") / "small.zarr"
    generate(str(path), 30, PERTURB, 5, split="small", examples_per_shard=8)
    return path


def test_pack_unpack_round_trip_for_odd_widths():
    rng = np.random.default_rng(0)
    for width in (8, 13, 640):
        m = rng.random((3, 7, width)) < 0.5
        np.testing.assert_array_equal(unpack(pack(m), width), m)


def test_statistics_of_packed_masks_equal_those_of_the_masks():
    """Empty masks, one pixel at each corner, regions touching the edges, several regions, odd
    widths; set padding bits are not pixels."""
    rng = np.random.default_rng(1)
    for width in (8, 13, 21, 640):
        masks = np.zeros((9, 11, width), bool)
        masks[1, 0, 0] = masks[2, -1, -1] = masks[3, 0, -1] = masks[4, -1, 0] = True
        masks[5, 2:9, width // 3 :] = True
        masks[6] = rng.random((11, width)) < 0.3
        masks[7, 1:3, 1:3] = masks[7, 6:10, width - 4 :] = True
        masks[8] = rng.random((11, width)) < 0.02
        packed = pack(masks)
        if width % 8:
            packed[0, 5, -1] |= 1  # a padding bit of an empty mask
            packed[5, 0, -1] |= 1  # and of one with pixels, above them
        stats = packed_stats(packed, width)
        for i, m in enumerate(masks):
            got = (stats.area[i], stats.largest_area[i], tuple(stats.bbox[i]))
            assert got == mask_stats(m), (width, i)


def test_frame_digests_from_their_drawn_rows_equal_the_whole_frames():
    rows = [(0, 0), (0, 7), (3, 5), (6, 9), (0, 9), (9, 9)]
    rng = np.random.default_rng(0)
    frames = np.zeros((len(rows), 9, 5), np.uint8)
    for frame, (y0, y1) in zip(frames, rows, strict=True):
        frame[y0:y1] = rng.integers(0, 256, (y1 - y0, 5), dtype=np.uint8)
    y0, y1 = (list(ends) for ends in zip(*rows, strict=True))
    z, depth = rng.random(len(rows)), np.where(np.arange(len(rows)) % 2, np.nan, 0.25)
    whole = frame_digests(frames, z, depth)
    padded = padded_frame_digests(frames, y0, y1, frame_tails(z, depth))
    np.testing.assert_array_equal(np.frombuffer(padded, np.uint8).reshape(-1, 32), whole)


def test_store_holds_what_the_generator_draws(small_zarr):
    with open_store(str(small_zarr)) as s:
        assert (s.n_examples, s.n_frames) == (30, 300)
        assert s.example_ids[7] == "small/000007"
        for i in (0, 7, 29):
            spec = sample_example(PERTURB, 5, i)
            ex = s.example(f"small/{i:06d}")
            expected = reference_masks(spec, PERTURB).astype(bool)
            np.testing.assert_array_equal(ex.masks, expected)
            np.testing.assert_array_equal(ex.z, spec.z)
            assert ex.d1 == spec.z[0]
            stats = stats_of(expected)
            np.testing.assert_array_equal(s.area[ex.frames], stats.area)
            np.testing.assert_array_equal(s.largest_area[ex.frames], stats.largest_area)
            np.testing.assert_array_equal(s.bbox[ex.frames], stats.bbox)


def test_digest_ignores_workers_shard_size_and_backend(tmp_path, small_zarr):
    reference = open_store(str(small_zarr)).attrs.digest
    a = generate(str(tmp_path / "a.zarr"), 30, PERTURB, 5, split="small", workers=2, examples_per_shard=5)
    b = generate(str(tmp_path / "b.h5"), 30, PERTURB, 5, split="small", workers=2, examples_per_shard=13)
    c = generate(str(tmp_path / "c.h5"), 30, PERTURB, 5, split="small", workers=1, examples_per_shard=30)
    assert a.digest == b.digest == c.digest == reference
    other = generate(str(tmp_path / "d.zarr"), 30, PERTURB, 6, split="small")
    assert other.digest != reference


def test_convert_streams_a_shard_at_a_time_and_reports_each(tmp_path):
    """A store of 1,300 frames in 10-frame chunks is copied in two shards of at most 1,024 frames
    (1,020 and 280), each written and counted as it is read."""
    src = tmp_path / "src.zarr"
    generate(str(src), 130, preset("perturb", image_size=(60, 80), sizes=(20,)), 1)
    for dst in (tmp_path / "out.h5", tmp_path / "back.zarr"):
        seen: list[tuple[str, int, int]] = []
        convert(str(src if dst.suffix == ".h5" else tmp_path / "out.h5"), str(dst),
                progress=lambda *report, seen=seen: seen.append(report))
        assert seen == [(str(dst), 1020, 1300), (str(dst), 1300, 1300)]
    assert zarr.open_array(str(tmp_path / "back.zarr" / "masks"), mode="r").shards[0] == 1020


def test_zarr_hdf5_round_trip_is_lossless(tmp_path, small_zarr):
    h5 = tmp_path / "copy.h5"
    back = tmp_path / "back.zarr"
    d1 = convert(str(small_zarr), str(h5))
    d2 = convert(str(h5), str(back))
    src = open_store(str(small_zarr))
    assert d1 == d2 == src.attrs.digest
    for path in (h5, back):
        with open_store(str(path)) as s:
            assert s.format == ("hdf5" if path.suffix == ".h5" else "zarr")
            for name in ("z", "depth", "area", "largest_area", "bbox", "frame_index", "d1"):
                np.testing.assert_array_equal(getattr(s, name), getattr(src, name))
            assert s.example_ids == src.example_ids
            np.testing.assert_array_equal(s.read_packed(0, s.n_frames), src.read_packed(0, src.n_frames))
            assert validate(str(path)).ok


def test_a_users_own_sparse_array_reads_the_same_after_a_store_is_opened(tmp_path, small_zarr):
    """odms-data's codecs (the bounded zstd, the refusal of a shard's missing chunk) apply to its
    own stores only: a valid sparse array of the user's, its unwritten chunks read as the fill
    value, reads the same before and after a store is opened and read through zarr."""
    sparse = zarr.create_array(str(tmp_path / "sparse.zarr"), shape=(8,), shards=(8,), chunks=(2,),
                               dtype="i4", fill_value=7)
    sparse[0:2] = [1, 2]
    before = zarr.open_array(str(tmp_path / "sparse.zarr"))[:]
    with open_store(str(small_zarr)) as s:
        assert s.backend.array("masks")[:].shape == (s.n_frames, s.height, (s.width + 7) // 8)
        assert len(s.example_ids) == s.n_examples
    after = zarr.open_array(str(tmp_path / "sparse.zarr"))[:]
    assert before.tolist() == after.tolist() == [1, 2, 7, 7, 7, 7, 7, 7]


def test_a_build_leaves_the_users_warnings_as_they_were(tmp_path):
    """The builder's check before its commit reads the store in its partial folder, beside the
    folder's marker, without zarr ever seeing the marker: the user's warnings filters are the same
    during and after a build, and a zarr warning that the user's own code raises in another thread
    meanwhile is shown, not swallowed (nor is any added)."""
    from zarr.errors import ZarrUserWarning

    from odms_data.outputs import MARKER

    building, emitted = threading.Event(), []

    def users_own_code() -> None:
        while building.is_set():
            emitted.append(len(emitted))
            warnings.warn(f"Object at {MARKER} is not recognized ({len(emitted)})", ZarrUserWarning,
                          stacklevel=1)

    with warnings.catch_warnings(record=True) as shown:
        warnings.simplefilter("always")
        filters = list(warnings.filters)
        building.set()
        thread = threading.Thread(target=users_own_code)
        thread.start()
        try:
            for k in range(3):
                generate(str(tmp_path / f"w{k}.zarr"), 4, PERTURB, k, examples_per_shard=2, workers=1)
        finally:
            building.clear()
            thread.join()
        assert warnings.filters == filters
    zarr_warnings = [w for w in shown if issubclass(w.category, ZarrUserWarning)]
    assert emitted and len(zarr_warnings) == len(emitted)


def test_validate_accepts_a_good_store(small_zarr):
    report = validate(str(small_zarr))
    assert report.ok, report.problems
    assert report.digest == open_store(str(small_zarr)).attrs.digest


def _copy(src: Path, dst: Path) -> Path:
    shutil.copytree(src, dst)
    return dst


def test_validate_finds_a_flipped_byte_in_a_shard(tmp_path, small_zarr):
    bad = _copy(small_zarr, tmp_path / "flip.zarr")
    shard = bad / "masks" / "c" / "1" / "0" / "0"
    data = bytearray(shard.read_bytes())
    data[len(data) // 3] ^= 0xFF
    shard.write_bytes(bytes(data))
    report = validate(str(bad))
    assert not report.ok
    assert any("frames" in p or "digest" in p for p in report.problems), report.problems


def test_validate_finds_a_missing_shard(tmp_path, small_zarr):
    bad = _copy(small_zarr, tmp_path / "missing.zarr")
    (bad / "masks" / "c" / "2" / "0" / "0").unlink()
    report = validate(str(bad))
    assert report.problems == ["array 'masks' lacks chunk c/2/0/0 (a damaged store)"], report.problems


def test_validate_finds_edited_attributes_and_statistics(tmp_path, small_zarr):
    bad = _copy(small_zarr, tmp_path / "attrs.zarr")
    meta = json.loads((bad / "zarr.json").read_text())
    meta["attributes"]["odms"]["counts"]["examples"] = 31
    (bad / "zarr.json").write_text(json.dumps(meta))
    assert any("shape" in p for p in validate(str(bad)).problems)

    bad2 = _copy(small_zarr, tmp_path / "stats.zarr")
    area = zarr.open_array(store=str(bad2), path="area", mode="r+")
    area[5] = area[5] + 1
    problems = validate(str(bad2)).problems
    assert any("differ from the masks at 1 frame(s), first 5" in p for p in problems), problems

    bad3 = _copy(small_zarr, tmp_path / "d1.zarr")
    zarr.open_array(store=str(bad3), path="d1", mode="r+")[3] = -1.0
    problems = validate(str(bad3)).problems
    assert any("d1 of example 'small/000003' is -1.0, not a positive depth" in p for p in problems)
    assert any("digest" in p for p in problems)


def test_validate_finds_a_truncated_array(tmp_path, small_zarr):
    bad = _copy(small_zarr, tmp_path / "trunc.zarr")
    meta_path = bad / "z" / "zarr.json"
    meta = json.loads(meta_path.read_text())
    meta["shape"] = [200]
    meta_path.write_text(json.dumps(meta))
    assert any("array 'z' has shape (200,)" in p for p in validate(str(bad)).problems)


def test_validate_reports_a_store_that_does_not_match_its_manifest(tmp_path):
    # a store calling itself sim-val but holding other content
    path = tmp_path / "fake.zarr"
    generate(str(path), 3, PRESETS["standard"], 1, split="sim-val")
    problems = validate(str(path)).problems
    assert any("differs from splits/sim-val.json" in p for p in problems), problems
    assert not any("generator version" in p for p in problems), problems


def test_a_store_from_before_the_generator_version_opens_as_version_1(tmp_path):
    path = tmp_path / "sim-val.zarr"
    attrs = generate(str(path), 3, PRESETS["standard"], 1, split="sim-val")
    assert attrs.generator["version"] == GENERATOR_VERSION == 2
    meta = json.loads((path / "zarr.json").read_text())
    del meta["attributes"]["odms"]["generator"]["version"]  # as written before the version existed
    (path / "zarr.json").write_text(json.dumps(meta))
    with open_store(str(path)) as s:
        assert s.attrs.generator_version == 1
    problems = validate(str(path)).problems
    assert any("made by generator version 1, the split is version 2's" in p for p in problems), problems


def test_incomplete_store_is_refused(tmp_path, small_zarr):
    bad = _copy(small_zarr, tmp_path / "incomplete.zarr")
    meta = json.loads((bad / "zarr.json").read_text())
    del meta["attributes"]["odms"]["complete"]
    (bad / "zarr.json").write_text(json.dumps(meta))
    with pytest.raises(StoreError, match="incomplete"):
        open_store(str(bad))
    assert any("incomplete" in p for p in validate(str(bad)).problems)


def test_existing_store_is_not_overwritten_without_asking(tmp_path):
    path = tmp_path / "x.zarr"
    first = generate(str(path), 2, PRESETS["standard"], 1)
    with pytest.raises(StoreExistsError, match="already exists") as refused:
        generate(str(path), 2, PRESETS["standard"], 2)
    assert refused.value.fix == "overwrite"
    assert open_store(str(path)).attrs.digest == first.digest
    second = generate(str(path), 2, PRESETS["standard"], 2, overwrite=True)
    assert open_store(str(path)).attrs.digest == second.digest != first.digest
    assert not Path(str(path) + ".replaced").exists()


def test_a_second_writer_is_refused_while_the_first_writes(tmp_path):
    path = tmp_path / "busy.zarr"
    with StoreWriter(str(path)):
        with pytest.raises(StoreLockedError, match="another odms-data process"):
            generate(str(path), 2, PRESETS["standard"], 1)
    generate(str(path), 2, PRESETS["standard"], 1)  # the lock is released afterwards
    assert open_store(str(path)).n_examples == 2


@pytest.mark.parametrize("name", ["fail.zarr", "fail.h5"])
def test_failed_write_leaves_nothing(tmp_path, name):
    def stop_after_first_shard(done: int) -> None:
        raise RuntimeError("stopped")

    with pytest.raises(RuntimeError, match="stopped"):
        generate(str(tmp_path / name), 20, PRESETS["standard"], 1, examples_per_shard=5,
                 progress=stop_after_first_shard)
    assert sorted(p.name for p in tmp_path.iterdir()) == []


def test_unknown_example_id_names_close_matches(small_zarr):
    with pytest.raises(InputError, match="did you mean small/000012"):
        open_store(str(small_zarr)).example("small/00012")


def test_recorded_z_oddities_are_one_warning_line(tmp_path):
    """A camera that stops in many examples: one warning line with a count, not one per example."""
    from _stores import make_store
    from broken_stores import edit_attrs

    path = tmp_path / "stops.zarr"
    make_store(path, "stops", [{"z": [0.5, 0.4], "areas": [64, 100], "d1": 0.5} for _ in range(3)])
    edit_attrs(lambda a: a.update(oddities=[{"example": f"stops/{i:03d}", "kind": "z-not-increasing",
                                             "detail": "the camera stops"} for i in range(3)]))(path)
    warnings = [w for w in validate(str(path)).warnings if "z is not strictly increasing" in w]
    assert warnings == ["example stops/000 and 2 more example(s): z is not strictly increasing "
                        "(recorded oddity)"]


def test_format_md_documents_every_array_of_the_table_with_its_dtype_and_rows(small_zarr):
    from odms_data.resources import resource_dir
    from odms_data.store.format import ARRAYS, arrays_of

    text = (resource_dir("schemas") / "FORMAT.md").read_text()
    table = re.findall(r"^\| `(\w+)` \| \((\w)[^|]*\| (\w+) \|", text, re.M)  # name, F or E, dtype
    documented = {name: (rows, dtype) for name, rows, dtype in table}
    tabled = {a.name: ("F" if a.per == "frame" else "E", np.dtype(a.dtype).name) for a in ARRAYS.values()}
    assert documented == tabled
    with open_store(small_zarr) as s:
        assert s.backend.names() == set(arrays_of("masks"))


def test_every_store_suffix_is_written_opened_and_found_as_its_backend(tmp_path):
    from _stores import make_store

    from odms_data.evaluation.ground_truth import find_stores
    from odms_data.store.format import SUFFIXES, store_path

    examples = [{"z": [1.0, 1.5], "areas": [36, 25], "d1": 0.5}]
    for fmt, suffixes in SUFFIXES.items():
        for suffix in suffixes:
            folder = tmp_path / suffix.lstrip(".")
            path = Path(make_store(folder / f"normal-val{suffix}", "normal-val", examples))
            with open_store(str(path)) as s:
                assert s.format == fmt
            assert find_stores([folder]) == {"normal-val": path}  # .hdf too, as the backends read it
        assert store_path(tmp_path, "normal-val", fmt) == tmp_path / f"normal-val{suffixes[0]}"
