"""Untrusted reads (issue 27): every reader of a store, a run folder or a JSON file, given a hostile
one (broken_stores.HOSTILE and the files below), refuses it with one line and exit code 2, in
bounded memory: each walk runs in a child process whose address space is capped (RLIMIT_AS) at
what it holds after its imports plus BUDGET."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from broken_stores import HOSTILE, broken_stores, make_valid

BUDGET = 2**30  # the bombs decode to 4 GiB; a bounded read needs a few megabytes
RUN_BUDGET = 2 * 2**30  # torch's thread pools take hundreds of MB; n_obs 10^6 would take 25 GB

# Runs each CLI invocation of stdin's "invocations" in this process, then the loaders over each of
# its "stores", and prints [[rc, stdout, stderr], ...] as JSON.
CHILD = r"""
import json, resource, sys, traceback
from click.testing import CliRunner
import cv2, h5py, matplotlib.pyplot, numcodecs, PIL.Image, torch, zarr, zstandard  # before the cap
from odms_data.cli import main
from odms_data.errors import OdmsError
from odms_data.loaders.numpy_loader import store_batches
import odms_data.store.backends.zarr_codecs, odms_data.network.prediction, odms_data.publish.hub_export

size = int(open("/proc/self/statm").read().split()[0]) * resource.getpagesize()
resource.setrlimit(resource.RLIMIT_AS, (size + int(sys.argv[1]), size + int(sys.argv[1])))
todo = json.loads(sys.stdin.read())
out = []
for args in todo["invocations"]:
    r = CliRunner().invoke(main, args)
    err = r.stderr
    if r.exit_code not in (0, 1, 2):
        err += "".join(traceback.format_exception(*r.exc_info))
    out.append([r.exit_code, r.stdout, err])
for store in todo["stores"]:
    try:
        for _ in store_batches(store, 2):
            pass
        out.append([0, "", ""])
    except OdmsError as e:
        out.append([2, "", f"odms-data: error: {e}\n"])
    except BaseException:
        out.append([3, "", traceback.format_exc()])
print(json.dumps(out))
"""


def run_limited(cwd: Path, invocations: list[list[str]], loader_stores: list[str] = (),
                budget: int = BUDGET) -> list[list]:
    """[rc, stdout, stderr] of each invocation, then of each loader walk, in one capped child."""
    todo = json.dumps({"invocations": invocations, "stores": list(loader_stores)})
    env = {**os.environ, "OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1"}  # buffers made lazily
    r = subprocess.run([sys.executable, "-c", CHILD, str(budget)], input=todo, cwd=cwd, capture_output=True,
                       text=True, timeout=600, env=env)
    assert r.returncode == 0, r.stderr[-3000:]
    return json.loads(r.stdout.strip().splitlines()[-1])


def assert_refused(result: list, what: str, names: str) -> None:
    rc, _, err = result
    lines = err.strip().splitlines()
    assert rc == 2 and len(lines) == 1 and lines[0].startswith("odms-data: error: "), (what, rc, err[-2000:])
    assert names in lines[0], (what, lines[0])


@pytest.fixture(scope="module")
def hostile(tmp_path_factory):
    root = tmp_path_factory.mktemp("hostile")
    valid = {"zarr": make_valid(root / "v.zarr"), "h5": make_valid(root / "v.h5")}
    rows = "".join(f"tiny,tiny/{i:06d},0.3\n" for i in range(4))
    (root / "p.csv").write_text("split,example_id,d1\n" + rows)
    return root, broken_stores(root, valid, HOSTILE)


def store_commands(store: str, out: str) -> dict[str, tuple[list[str], str | None]]:
    """command -> (its arguments, the output it writes)."""
    other = out + (".zarr" if store.endswith(".h5") else ".h5")
    return {
        "info": (["info", "--json", store], None),
        "show": (["show", store, "tiny/000001", "-o", f"{out}.png"], f"{out}.png"),
        "score": (["score", "p.csv", "--data", store], None),
        "baseline": (["baseline", "vosde", store, "-o", f"{out}.csv"], f"{out}.csv"),
        "convert": (["convert", store, other], other),
        "export": (["export", store, "-o", f"{out}-hub"], f"{out}-hub"),
    }


# the commands that read none of the array a damage touches (info reads the attributes, score
# the labels and ids, the VOS-DE baseline the stored areas)
UNMASKED = ("info", "score", "baseline")
UNREAD = {"zstd bomb in a mask chunk": UNMASKED, "zstd bomb in a z chunk": ("info", "score"),
          "gzip bomb in a mask chunk": UNMASKED, "a mask chunk missing": UNMASKED,
          "a FIFO for the mask shard": UNMASKED, "a FIFO for a z chunk": ("info", "score")}
NAMES = [f"{name} ({backend})" for name, (backends, _) in HOSTILE.items() for backend in backends.split()]


@pytest.mark.parametrize("name", NAMES)
def test_every_store_reader_refuses_a_hostile_store(hostile, name, tmp_path):
    root, stores = hostile
    store = str(stores[name].relative_to(root))
    commands = store_commands(store, str(tmp_path / "out"))
    results = run_limited(root, [["validate", store], *(args for args, _ in commands.values())], [store])
    rc, out, err = results[0]
    assert rc == 1 and "INVALID" in out and "Traceback" not in err, (name, rc, out, err[-2000:])
    for (command, (_, output)), result in zip([*commands.items(), ("loaders", ([], None))], results[1:],
                                             strict=True):
        if result[0] == 0 and command in UNREAD.get(name.split(" (")[0], ()):
            continue  # the command never reads the damaged array: it costs it nothing
        assert_refused(result, f"{name}: {command}", store)
        assert output is None or not Path(output).exists(), (name, command, "left", output)


def test_validate_names_each_hostile_class(hostile):
    root, stores = hostile
    expect = {"zstd bomb in a mask chunk (zarr)": "does not decode",
              "gzip bomb in a mask chunk (h5)": "inflate",
              "10^8 frames declared (zarr)": "times the", "3x10^9 frames declared (h5)": "times the",
              "a mask chunk missing (zarr)": "missing",
              "a mask chunk missing (h5)": "holds 11 of its 12 chunks",
              "masks an external link (h5)": "ExternalLink",
              "masks a virtual dataset (h5)": "virtual dataset",
              "attributes nested 100,000 deep (zarr)": "nested deeper",
              "a chunk shape with an empty side (zarr)": "with an empty side",
              "every chunk index damaged (h5)": "wrong B-tree signature",
              "a FIFO for the mask shard (zarr)": "is a FIFO",
              "a FIFO for a z chunk (zarr)": "not a regular file",
              "a FIFO for the store (h5)": "a FIFO, device or socket"}
    results = run_limited(root, [["validate", str(stores[n].relative_to(root))] for n in expect])
    for (name, fragment), (_, out, _) in zip(expect.items(), results, strict=True):
        assert fragment in out, (name, out)


def test_json_everywhere_is_depth_bounded(tmp_path):
    deep = "[" * 100_000 + "]" * 100_000
    (tmp_path / "board").mkdir()
    (tmp_path / "board" / "e.json").write_text(deep)
    (tmp_path / "run").mkdir()
    (tmp_path / "run" / "config.json").write_text(deep)
    results = run_limited(tmp_path, [
        ["generate", "-n", "2", "--param", f"d_max={deep}", "-o", "g.zarr"],
        ["leaderboard", "--dir", "board"],
        ["predict", "run", "--data", ".", "-o", "p.csv", "--device", "cpu"],
    ])
    pairs = (("--param", "--param"), ("leaderboard", "e.json"))
    for (what, names), result in zip(pairs, results[:2], strict=True):
        assert_refused(result, what, names)
        assert "nested deeper than 64" in result[2], (what, result[2])
    assert_refused(results[2], "run config", "not a training run")  # a config odms-data did not write
    assert not (tmp_path / "g.zarr").exists()


def test_json_numbers_everywhere_are_finite_and_bounded(tmp_path):
    """A 401-digit integer overflowed the float a leaderboard cell takes (OverflowError, exit 3);
    every JSON reader now refuses it, and 1e400, naming the file."""
    entry = json.loads((Path(__file__).parents[1] / "leaderboard" / "box_ls.json").read_text())
    split = next(iter(entry["results"].values()))
    next(iter(split.values()))["percent"] = "HUGE"
    (tmp_path / "board").mkdir()
    (tmp_path / "board" / "e.json").write_text(json.dumps(entry).replace('"HUGE"', "1" + "0" * 400))
    store = make_valid(tmp_path / "s.zarr")
    meta = (store / "zarr.json").read_text()
    (store / "zarr.json").write_text(meta.replace('"attributes": {', '"attributes": {"x": 1e400, ', 1))
    results = run_limited(tmp_path, [["leaderboard", "--dir", "board"], ["info", "s.zarr"]])
    assert_refused(results[0], "leaderboard", "an integer of 401 digits, more than 20")
    assert_refused(results[1], "info", "the number 1e400 is too large")


def test_a_run_folder_is_checked_before_anything_is_built(tmp_path):
    import torch

    config = {"model": "odn-l", "n_obs": 10, "val": ["v.zarr"], "seed": 123}
    runs = {"huge": {**config, "n_obs": 1_000_000}, "list": config, "no-model": config,
            "half": {**config, "n_obs": 2.5}, "letters": {**config, "val": "v.zarr"},
            "seed": {**config, "seed": 2**64}}
    for name, c in runs.items():
        (tmp_path / name).mkdir()
        (tmp_path / name / "config.json").write_text(json.dumps({"config": c, "odms_data": "0"}))
    make_valid(tmp_path / "v.zarr")
    torch.save([1, 2, 3], tmp_path / "list" / "best.pt")
    torch.save({"iteration": 3, "model": [torch.zeros(2)]}, tmp_path / "no-model" / "best.pt")
    invocations = [["predict", name, "--data", "v.zarr", "-o", f"{name}.csv", "--device", "cpu"]
                   for name in runs]
    results = run_limited(tmp_path, invocations, budget=RUN_BUDGET)
    assert_refused(results[0], "huge", "n_obs must be at most 100")
    assert_refused(results[1], "list", "holds a list, not a dict")
    assert_refused(results[2], "no-model", "'model' is list, not dict")
    assert_refused(results[3], "half", "n_obs must be a whole number, got 2.5")
    assert_refused(results[4], "letters", "val must be a list of strings, got 'v.zarr'")
    assert_refused(results[5], "seed", f"seed must be at most {2**64 - 1}")


def test_predict_never_predicts_from_a_missing_chunk(hostile):
    import torch

    from odms_data.network import odn
    from odms_data.network.variants import variant

    root, stores = hostile
    run = root / "run"
    run.mkdir(exist_ok=True)
    config = {"model": "odn-l", "n_obs": 3, "val": ["v.zarr"], "seed": 123}
    (run / "config.json").write_text(json.dumps({"config": config, "odms_data": "0"}))
    torch.save({"iteration": 1, "model": odn.build(variant("odn-l"), 3, False).state_dict()}, run / "best.pt")
    store = str(stores["a mask chunk missing (zarr)"].relative_to(root))
    results = run_limited(root, [["predict", "run", "--data", store, "-o", f"p{w}.csv", "--device", "cpu",
                                  "--workers", str(w)] for w in (0, 2)], budget=RUN_BUDGET)
    for w, result in zip((0, 2), results, strict=True):
        assert_refused(result, f"predict --workers {w}", "chunk 1 of the shard is missing")
        assert not (root / f"p{w}.csv").exists()


def _detection_files(root: Path) -> list[tuple[list[str], str]]:
    """Hostile detection and pose files for `import detections`: (arguments, what the line names)."""
    poses = "".join(f"1 0 0 0 0 1 0 0 0 0 1 {-0.1 * i:.3f} 0 0 0 1\n" for i in range(4))
    (root / "c2w.txt").write_text(poses)
    mot = ["import", "detections", "--from", "mot", "--track", "1", "--image-size", "64x48",
           "--poses", "c2w.txt"]
    files = {
        "m1.txt": "1," * 10**6 + "1\n",
        "m2.txt": "1,1,2,2,3,3,0.9\n2,1,2,2,3\n",
        "labels/f1.txt": "0 " + "0.5 " * 10**6 + "\n",
        "labels2/f1.txt": "0 0.5 0.5 nan 0.1\n",
        "deep.json": "[" * 100_000 + "]" * 100_000,
        "images.json": json.dumps({"images": [{"id": i, "file_name": f"{i}.png", "width": 64, "height": 48}
                                              for i in range(4)]}),
        "bbox.json": json.dumps([{"image_id": 1, "category_id": 1, "bbox": [1, 2, 3], "score": 0.5}]),
        "id.json": '[{"image_id": 1' + "0" * 400 + ', "category_id": 1, "bbox": [1, 2, 3, 4], "score": 1}]',
        "huge.json": json.dumps({"images": [{"id": 1, "file_name": "a.png", "width": 10**6,
                                              "height": 10**6}]}),
        "tum-nan.txt": "1 0 0 0 0 0 0 1\n2 nan 0 0 0 0 0 1\n",
        "tum-q.txt": "1 0 0 0 0 0 0 1.01\n",
        "scaled.txt": " ".join(map(str, np.diag([2, 1, 1, 1]).ravel())) + "\n",
    }
    for name, text in files.items():
        (root / name).parent.mkdir(exist_ok=True)
        (root / name).write_text(text)
    with open(root / "big.json", "wb") as f:  # sparse: larger than a COCO file may be, nothing written
        f.truncate((1 << 30) + 1)
    coco = ["import", "detections", "--category", "1", "--poses", "c2w.txt"]
    return [
        (mot + ["m1.txt"], "m1.txt line 1: longer than a row can be"),
        (mot + ["m2.txt"], "m2.txt line 2: 5 fields; a MOTChallenge row has 6 to 10"),
        (["import", "detections", "labels", "--image-size", "64x48", "--poses", "c2w.txt"],
         "f1.txt: 4000003 bytes, more than a YOLO label file may have"),  # 10^6 fields
        (["import", "detections", "labels2", "--image-size", "64x48", "--poses", "c2w.txt"],
         "f1.txt line 1: w 'nan' is not a finite number"),
        (coco + ["deep.json", "--images", "images.json"], "deep.json: JSON nested deeper than 64"),
        (coco + ["bbox.json", "--images", "deep.json"], "deep.json: JSON nested deeper than 64"),
        (coco + ["bbox.json", "--images", "images.json"], "bbox.json entry 0: bbox is not 4 numbers"),
        (coco + ["id.json", "--images", "images.json"], "id.json: not valid JSON (an integer of 401 digits"),
        (coco + ["bbox.json", "--images", "huge.json"], "huge.json images[0]: image size 1000000x1000000"),
        (coco + ["big.json", "--images", "images.json"], "big.json: 1073741825 bytes, more than a COCO"),
        (mot + ["m2.txt", "--poses", "tum-nan.txt", "--fps", "1"], "tum-nan.txt line 2, field 2: 'nan'"),
        (mot + ["m2.txt", "--poses", "tum-q.txt", "--fps", "1"], "tum-q.txt line 1: quaternion qx qy qz qw"),
        (mot + ["m2.txt", "--poses", "scaled.txt"], "scaled.txt line 1: the rotation part is not"),
    ]


def test_every_detection_reader_refuses_a_hostile_file_in_one_line(tmp_path):
    """MOTChallenge, YOLO and COCO files (a line of 10^6 fields, JSON 100,000 deep, a 401-digit id, a
    file past the size bound, an image of 10^12 pixels, bad rows) and pose files (NaN, a non-unit
    quaternion, a matrix that is not a rotation): one line naming the file and row, exit code 2,
    in bounded memory, nothing written."""
    cases = _detection_files(tmp_path)
    results = run_limited(tmp_path, [args + ["-o", f"out{k}.zarr"] for k, (args, _) in enumerate(cases)])
    for (args, says), result in zip(cases, results, strict=True):
        assert_refused(result, " ".join(args)[:80], says)
    assert not list(tmp_path.glob("out*"))
