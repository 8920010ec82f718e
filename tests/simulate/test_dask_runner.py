"""Generating on Dask: a default deployment of `dask scheduler` and `dask worker` processes and
LocalClusters give a local run's digest, survive a killed worker, write URLs."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time
from pathlib import Path

import cloudpickle
import dask
import distributed
import pytest
from click.testing import CliRunner

from odms_data.cli import main
from odms_data.errors import InputError
from odms_data.simulate.generate_store import generate
from odms_data.simulate.params import preset
from odms_data.simulate.shard_task import ShardTask
from odms_data.simulate.shards import run_shard
from odms_data.store.backends import MaskSink
from odms_data.store.reader import open_store
from odms_data.store.validate import validate

COUNT, SEED, PER_SHARD = 96, 11, 4  # 24 shards: enough tasks to kill a worker in the middle
PARAMS = preset("standard", image_size=(120, 160), sizes=(30, 60))


def _cluster(processes: bool) -> distributed.LocalCluster:
    return distributed.LocalCluster(
        n_workers=2, processes=processes, threads_per_worker=1, dashboard_address=":0"
    )


@pytest.fixture(scope="module")
def cluster():
    with _cluster(processes=True) as c:
        yield c


@pytest.fixture(scope="module")
def local_digest(tmp_path_factory) -> str:
    path = tmp_path_factory.mktemp("local") / "local.zarr"
    return generate(str(path), COUNT, PARAMS, SEED, workers=1).digest


def _check(path: str, digest: str) -> None:
    store = open_store(path)  # raises unless complete
    assert store.attrs.digest == digest
    report = validate(path)
    assert report.ok, report.problems
    assert report.digest == digest


def test_same_digest_as_a_local_run(cluster, local_digest, tmp_path):
    path = str(tmp_path / "dask.zarr")
    seen = []
    attrs = generate(path, COUNT, PARAMS, SEED, examples_per_shard=PER_SHARD,
                     scheduler=cluster.scheduler_address, progress=seen.append)
    assert attrs.digest == local_digest
    assert sum(seen) == COUNT and len(seen) == COUNT // PER_SHARD
    assert not os.path.exists(path + ".partial")
    _check(path, local_digest)


@pytest.fixture(scope="module")
def deployment(tmp_path_factory):
    """A default deployment, as docs/DISTRIBUTED.md starts one: a `dask scheduler` process and a
    `dask worker --nworkers 2 --nthreads 1` process (its workers under nannies); the address."""
    tmp = tmp_path_factory.mktemp("dask")
    dask, file = Path(sys.executable).with_name("dask"), tmp / "scheduler.json"
    common = ["--no-dashboard", "--scheduler-file", str(file)]
    log = open(tmp / "dask.log", "w")  # noqa: SIM115  # closed with the processes
    procs = [subprocess.Popen([dask, "scheduler", "--host", "127.0.0.1", "--port", "0", *common],
                              stdout=log, stderr=subprocess.STDOUT)]
    procs.append(subprocess.Popen([dask, "worker", "--nworkers", "2", "--nthreads", "1", *common],
                                  stdout=log, stderr=subprocess.STDOUT))
    try:
        deadline = time.monotonic() + 120
        while not file.exists() and time.monotonic() < deadline:
            time.sleep(0.1)
        address = json.loads(file.read_text())["address"]
        with distributed.Client(address, timeout=60, set_as_default=False) as client:
            client.wait_for_workers(2, timeout=120)
        yield address
    finally:
        for p in reversed(procs):
            p.terminate()
            p.wait(60)
        log.close()


def _trim_threshold() -> str | None:
    import os  # the worker's, not a pickled copy of this process's os.environ

    return os.environ.get("MALLOC_TRIM_THRESHOLD_")


def test_a_default_deployment_gives_the_local_digest(deployment, local_digest, tmp_path):
    with distributed.Client(deployment, set_as_default=False) as client:
        cloudpickle.register_pickle_by_value(sys.modules[__name__])  # workers cannot import this file
        try:
            trims = client.run(_trim_threshold)
        finally:
            cloudpickle.unregister_pickle_by_value(sys.modules[__name__])
        pids = client.run(os.getpid)
    assert len(trims) == 2 and set(trims.values()) == {"65536"}  # nannies set it in their workers
    assert len(set(pids.values())) == 2 and os.getpid() not in pids.values()  # worker processes
    path = str(tmp_path / "deployed.zarr")
    generate(path, COUNT, PARAMS, SEED, examples_per_shard=PER_SHARD, scheduler=deployment)
    _check(path, local_digest)


def test_hdf5(cluster, local_digest, tmp_path):
    """HDF5 tasks return their compressed chunks; the client writes them, as locally."""
    path = str(tmp_path / "dask.h5")
    generate(path, COUNT, PARAMS, SEED, examples_per_shard=PER_SHARD, scheduler=cluster.scheduler_address)
    _check(path, local_digest)


def test_file_url(cluster, local_digest, tmp_path):
    url = f"file://{tmp_path}/url/dask.zarr"
    generate(url, COUNT, PARAMS, SEED, examples_per_shard=PER_SHARD, scheduler=cluster.scheduler_address)
    _check(url, local_digest)


def test_cli(cluster, local_digest, tmp_path):
    out = tmp_path / "cli.zarr"
    args = ["generate", "-n", str(COUNT), "--seed", str(SEED), "--param", "image_size=[120, 160]",
            "--param", "sizes=[30, 60]", "-o", str(out), "--scheduler", cluster.scheduler_address]
    result = CliRunner().invoke(main, args)
    assert result.exit_code == 0, result.output
    assert local_digest in result.output
    result = CliRunner().invoke(main, [*args, "--workers", "2", "--overwrite"])
    assert result.exit_code == 2 and "--workers and --scheduler exclude each other" in result.output


def test_boxes_on_the_cluster_give_one_local_workers_digest(cluster, tmp_path):
    digests = []
    for name, more in (("local", ["--workers", "1"]), ("dask", ["--scheduler", cluster.scheduler_address])):
        res = CliRunner().invoke(main, ["generate", "-n", "30", "--boxes", "odmd-perturb-motion",
                                        "--seed", "4", "--examples-per-shard", "4",
                                        "-o", str(tmp_path / f"{name}.zarr"), "--json", *more])
        assert res.exit_code == 0, res.output
        digests.append(json.loads(res.stdout[res.stdout.index("{"):])["digest"])
        _check(str(tmp_path / f"{name}.zarr"), digests[-1])
    assert digests[0] == digests[1]


def test_memory_url_needs_an_in_process_cluster(cluster, local_digest):
    with pytest.raises(InputError, match="memory:// store lives in this process"):
        generate("memory://odms-test/procs.zarr", COUNT, PARAMS, SEED, scheduler=cluster.scheduler_address)
    with _cluster(processes=False) as threads:
        url = "memory://odms-test/threads.zarr"
        generate(url, COUNT, PARAMS, SEED, examples_per_shard=PER_SHARD, scheduler=threads.scheduler_address)
        _check(url, local_digest)


class _DieOnce(distributed.WorkerPlugin):
    """Crashes its worker as it starts its third shard: one worker in the whole cluster, once."""

    def __init__(self, marker: str) -> None:
        self.marker, self.started = marker, 0

    def transition(self, key, start, finish, **kwargs) -> None:
        if finish != "executing":
            return
        self.started += 1
        if self.started == 3:
            try:
                os.close(os.open(self.marker, os.O_CREAT | os.O_EXCL))
            except FileExistsError:
                return
            os._exit(1)


def test_killed_worker_leaves_a_complete_correct_store(local_digest, tmp_path):
    marker = tmp_path / "a-worker-died"
    cloudpickle.register_pickle_by_value(sys.modules[__name__])  # workers cannot import this file
    # a result still held by the dead worker is recomputed once fetching it has timed out (30 s default)
    try:
        with dask.config.set({"distributed.comm.timeouts.connect": "3s"}), _cluster(processes=True) as c, \
                distributed.Client(c, set_as_default=False) as client:
            client.register_plugin(_DieOnce(str(marker)))
            path = str(tmp_path / "killed.zarr")
            generate(path, COUNT, PARAMS, SEED, examples_per_shard=PER_SHARD, scheduler=c.scheduler_address)
            client.wait_for_workers(2, timeout=60)  # closing a cluster whose nanny is restarting can hang
    finally:
        cloudpickle.unregister_pickle_by_value(sys.modules[__name__])
    assert marker.exists()
    _check(path, local_digest)


def test_a_rerun_task_rewrites_a_half_written_shard(local_digest, tmp_path):
    """What a worker killed mid-write leaves (a truncated shard over file://) is replaced whole."""
    url = f"file://{tmp_path}/half.zarr"
    generate(url, COUNT, PARAMS, SEED, examples_per_shard=PER_SHARD)
    shard = tmp_path / "half.zarr" / "masks" / "c" / "1" / "0" / "0"
    whole = shard.read_bytes()
    shard.write_bytes(whole[: len(whole) // 2])
    sink = MaskSink(url, "zarr", PARAMS.n_obs)
    run_shard(ShardTask(sink, PARAMS, SEED, "generated", COUNT, PER_SHARD, 2 * PER_SHARD))
    assert shard.read_bytes() == whole
    _check(url, local_digest)


def test_no_dask_without_a_scheduler(tmp_path):
    code = (
        "import sys; from odms_data.simulate.generate_store import generate; "
        "from odms_data.simulate.params import preset; "
        "import odms_data.cli; "
        f"generate({str(tmp_path / 'x.zarr')!r}, 4, preset('standard', image_size=(60, 80), sizes=(20,)),"
        " 0); "
        "assert not {'dask', 'distributed'} & set(sys.modules), 'dask imported'"
    )
    subprocess.run([sys.executable, "-c", code], check=True)
