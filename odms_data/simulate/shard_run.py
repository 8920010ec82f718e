"""The function a shard task is handed to workers with: light, the renderer (shards.py) imported
only where the task runs, so that the process handing tasks out never loads it."""

from __future__ import annotations

from ..store.build import Rows
from .shard_task import ShardTask


def run(task: ShardTask) -> Rows:
    """shards.run_shard(task), the renderer imported where the task runs."""
    from .shards import run_shard

    return run_shard(task)
