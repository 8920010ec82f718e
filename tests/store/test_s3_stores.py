"""Stores on S3, as docs/DISTRIBUTED.md tells users to write them: a real S3 server (moto's, on a free
local port) reached through s3fs, its endpoint given the documented way (FSSPEC_S3, credentials in
the environment). The commands and loaders read such a store as they read a local one, an existing
one is not replaced without --overwrite, and the file tests' hostile stores are refused over s3://
too, in bounded memory."""

from __future__ import annotations

import json
import logging
import subprocess
import sys

import fsspec
import numpy as np
import pytest
import s3fs
from broken_stores import HOSTILE, broken_stores, make_valid
from click.testing import CliRunner, Result
from test_untrusted_reads import assert_refused, run_limited

from odms_data.cli import main
from odms_data.errors import StoreError
from odms_data.loaders.numpy_loader import store_batches
from odms_data.simulate.generate_store import generate
from odms_data.simulate.params import preset
from odms_data.store.reader import open_store

BUCKET = "odms"
ARGS = ["-n", "12", "--preset", "perturb", "--seed", "3", "--n-obs", "5", "--param", "image_size=[96,128]",
        "--param", "sizes=[20,40]", "--examples-per-shard", "5"]
PARAMS = preset("perturb", n_obs=5, image_size=(96, 128), sizes=(20, 40))
# the file tests' hostile Zarr stores (broken_stores.HOSTILE) put on S3 -> (a command that reads
# what the damage touches, its arguments after the store): each reaches S3 in its own way
SHOW = (["show"], ["tiny/000001", "-o", "sheet.png"])
CASES = {
    "attributes nested 100,000 deep": (["info"], []),  # zarr.json read through fsspec, bounded
    "10^8 frames declared": (["info"], []),  # the bytes a store holds, summed over its objects
    "the mask shard missing": SHOW,  # the objects of an array, listed
    "a mask chunk missing": SHOW,  # a shard's index, read by range through zarr
    "zstd bomb in a mask chunk": SHOW,
}


@pytest.fixture(scope="module")
def s3():
    """The S3 filesystem of a fresh local server holding an empty bucket; this process and the
    commands it starts reach it through FSSPEC_S3 and the AWS_* variables, as a user's would."""
    from moto.server import ThreadedMotoServer

    logging.getLogger("werkzeug").setLevel(logging.WARNING)  # a line per request otherwise
    server = ThreadedMotoServer(ip_address="127.0.0.1", port=0, verbose=False)
    server.start()
    host, port = server.get_host_and_port()
    with pytest.MonkeyPatch.context() as mp:
        for name, value in {"AWS_ACCESS_KEY_ID": "test", "AWS_SECRET_ACCESS_KEY": "test",
                            "AWS_DEFAULT_REGION": "us-east-1",
                            "FSSPEC_S3": json.dumps({"endpoint_url": f"http://{host}:{port}"})}.items():
            mp.setenv(name, value)
        mp.setattr(fsspec.config, "conf", {})
        fsspec.config.set_conf_env(fsspec.config.conf)  # what fsspec does with FSSPEC_S3 when imported
        s3fs.S3FileSystem.clear_instance_cache()
        fs = s3fs.S3FileSystem()
        fs.mkdir(BUCKET)
        yield fs
        _close_sessions()
    server.stop()


def _close_sessions() -> None:
    """Close the connections of the S3 filesystems made in this process, then forget them. s3fs
    closes one only when it is collected, giving the close 0.1 s on its event loop, and not at all
    for an asynchronous one (zarr's, on zarr's loop): aiohttp then warns that a session was never
    closed."""
    from fsspec.asyn import sync
    from zarr.core.sync import sync as zarr_sync

    for fs in list(s3fs.S3FileSystem._cache.values()):
        client = getattr(fs, "_s3creator", None)
        if client is None:
            continue
        if fs.asynchronous:  # made by zarr, its session on zarr's event loop
            zarr_sync(client.__aexit__(None, None, None))
        else:
            sync(fs.loop, client.__aexit__, None, None, None)
    s3fs.S3FileSystem.clear_instance_cache()


def odms(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "odms_data.cli", *args], capture_output=True, text=True)


def cli(*args: str) -> Result:
    """A command run in this process (the fixture configured its fsspec as FSSPEC_S3 does)."""
    return CliRunner().invoke(main, list(args))


def test_a_store_generated_to_s3_reads_as_a_local_one(s3, tmp_path, monkeypatch):
    url = f"s3://{BUCKET}/odms/gen.zarr"
    r = odms("generate", *ARGS, "--workers", "2", "-o", url)  # as users do: workers write shards to S3
    assert r.returncode == 0, r.stderr
    local = generate(str(tmp_path / "local.zarr"), 12, PARAMS, 3, examples_per_shard=5)
    assert local.digest in r.stdout
    monkeypatch.chdir(tmp_path)
    assert f"{url}: valid, digest {local.digest}" in cli("validate", url).stdout
    assert json.loads(cli("info", "--json", url).stdout)["digest"] == local.digest
    assert cli("show", url, "generated/000004", "-o", "sheet.png").exit_code == 0
    assert (tmp_path / "sheet.png").stat().st_size > 1000
    for store, out in ((url, "s3.csv"), ("local.zarr", "local.csv")):
        assert cli("baseline", "vosde", store, "--n-obs", "5", "-o", out).exit_code == 0
    assert (tmp_path / "s3.csv").read_text() == (tmp_path / "local.csv").read_text()
    scored = cli("score", "s3.csv", "--data", url, "--json")
    assert scored.exit_code == 0, scored.stderr
    assert json.loads(scored.stdout)["splits"][0]["n"] == 12
    got = list(store_batches(url, 5))
    want = list(store_batches("local.zarr", 5))
    assert len(got) == len(want) == 3
    for g, w in zip(got, want, strict=True):
        assert g.keys() == w.keys() and all(np.array_equal(g[k], w[k]) for k in g)
    # a loader's worker processes open the store themselves; a fresh program, as a user's starts
    # with the variables set (a fork server started earlier in this process has an older environment)
    same = subprocess.run([sys.executable, "-c", LOADER_WITH_WORKERS, url, "local.zarr"],
                          capture_output=True, text=True)
    assert same.stdout.strip() == "3 batches, equal", same.stderr


LOADER_WITH_WORKERS = """
import sys
import numpy as np
from odms_data.loaders.numpy_loader import store_batches
got = list(store_batches(sys.argv[1], 5, workers=2))
want = list(store_batches(sys.argv[2], 5))
equal = len(got) == len(want) and all(
    g.keys() == w.keys() and all(np.array_equal(g[k], w[k]) for k in g) for g, w in zip(got, want))
print(len(got), "batches,", "equal" if equal else "different")
"""


def test_a_store_on_s3_is_replaced_only_with_overwrite(s3, tmp_path):
    url = f"s3://{BUCKET}/odms/replaced.zarr"
    with pytest.raises(StoreError, match=r"replaced\.zarr: no such store"):
        open_store(url)
    first = generate(url, 4, PARAMS, 3).digest
    r = cli("generate", *ARGS, "--seed", "4", "-o", url)
    assert r.exit_code == 2, r.stderr
    assert r.stderr == f"odms-data: error: {url}: already exists; pass --overwrite to replace it\n"
    assert open_store(url).attrs.digest == first
    replaced = generate(url, 4, PARAMS, 4, overwrite=True).digest
    assert replaced != first and open_store(url).attrs.digest == replaced
    s3.pipe(f"{BUCKET}/odms/photos.zarr/photo.jpg", b"\xff\xd8 a photo")
    r = cli("generate", *ARGS, "-o", f"s3://{BUCKET}/odms/photos.zarr", "--overwrite")
    assert r.exit_code == 2 and "not an odms-data store" in r.stderr, r.stderr
    assert s3.find(f"{BUCKET}/odms/photos.zarr") == [f"{BUCKET}/odms/photos.zarr/photo.jpg"]


@pytest.fixture(scope="module")
def hostile_urls(s3, tmp_path_factory):
    """{case: its store's URL}: the file tests' hostile Zarr stores, made locally, put on S3."""
    root = tmp_path_factory.mktemp("s3-hostile")
    damages = {name: ("zarr", HOSTILE[name][1]) for name in CASES}
    made = broken_stores(root, {"zarr": make_valid(root / "v.zarr")}, damages)
    urls = {}
    for i, name in enumerate(CASES):
        urls[name] = f"s3://{BUCKET}/hostile/h{i}.zarr"
        s3.put(str(made[f"{name} (zarr)"]), urls[name].removeprefix("s3://"), recursive=True)
    return root, urls


def test_a_hostile_store_on_s3_is_refused_in_one_line(hostile_urls):
    """validate finds each hostile store at an s3:// URL invalid, and a reader of what it damages
    refuses it in one line, exit 2, in bounded memory (the file tests walk every reader)."""
    root, urls = hostile_urls
    invocations = [["validate", url] for url in urls.values()]
    invocations += [[*args, url, *more]
                    for (args, more), url in zip(CASES.values(), urls.values(), strict=True)]
    masks = [urls["a mask chunk missing"]]  # read by the loaders too
    results = run_limited(root, invocations, masks)
    for name, (rc, out, err) in zip(urls, results[:len(urls)], strict=True):
        assert rc == 1 and "INVALID" in out and "Traceback" not in err, (name, rc, out, err[-2000:])
    for (name, url), result in zip(urls.items(), results[len(urls):len(urls) * 2], strict=True):
        assert_refused(result, name, url)
    assert not (root / "sheet.png").exists()
    for url, result in zip(masks, results[len(urls) * 2:], strict=True):
        assert_refused(result, f"{url}: loaders", url)
