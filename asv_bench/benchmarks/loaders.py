"""Examples/s of the streaming loader: generated examples as the paper's 112x112 inputs, in
process and with two worker processes."""

from __future__ import annotations

from odms_data.loaders import stream_batches

BATCH = 32
BATCHES = 4


class Stream:
    params = [0, 2]
    param_names = ["workers"]
    timeout = 300

    def time_stream_batches(self, workers: int) -> None:
        for _ in stream_batches(BATCH, BATCHES, workers=workers):
            pass
