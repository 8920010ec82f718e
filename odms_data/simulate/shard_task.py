"""What one shard task of a generated store is; shards.py runs it (through
generate_store.run_task).

Light: the process that hands tasks out (to local workers or a Dask cluster) imports this, not
the renderer, whose imports (Numba, OpenCV) it would pay for and never use.
"""

from __future__ import annotations

from dataclasses import dataclass

from ..store.backends import MaskSink
from .params import GeneratorParams

SOURCE = "generated"


def example_ids(split: str, count: int, start: int, stop: int) -> list[str]:
    """Ids `<split>/<index>` zero-padded to at least 6 digits."""
    digits = max(6, len(str(count - 1)))
    return [f"{split}/{i:0{digits}d}" for i in range(start, stop)]


@dataclass
class ShardTask:
    """Examples [start, stop) of a generated store, their masks written through `sink`."""

    sink: MaskSink  # where the masks go
    params: GeneratorParams
    seed: int
    split: str
    count: int
    start: int
    stop: int
