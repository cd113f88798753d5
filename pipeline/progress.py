"""Progress display for long work (batch IK, benchmarks, big jobs): a one-line counter on a terminal,
silent when standard error is not a terminal (pipes, CI, notebooks, tests) or PIPELINE_PROGRESS=0."""

from __future__ import annotations

import os
import sys
import time

#: Redraw at most this often [s].
REDRAW_INTERVAL = 0.2


def progress_enabled(stream=None) -> bool:
    """True when the stream (default stderr) is a terminal and PIPELINE_PROGRESS is not "0"."""
    stream = sys.stderr if stream is None else stream
    return os.environ.get("PIPELINE_PROGRESS", "1") != "0" and hasattr(stream, "isatty") and stream.isatty()


class Progress:
    """``with Progress(total, "IK gp7") as tick: ... tick()`` draws ``IK gp7: 120/1000 (12 %) 3.1 s``."""

    def __init__(self, total: int, label: str, stream=None):
        self.total, self.label = total, label
        self.stream = sys.stderr if stream is None else stream
        self.enabled = progress_enabled(self.stream) and total > 0
        self.done = 0
        self._start = self._drawn = time.perf_counter()

    def __enter__(self) -> "Progress":
        return self

    def __call__(self, steps: int = 1) -> None:
        self.done += steps
        now = time.perf_counter()
        if self.enabled and (now - self._drawn >= REDRAW_INTERVAL or self.done >= self.total):
            self._drawn = now
            self.stream.write(f"\r{self.label}: {self.done}/{self.total} ({100 * self.done // self.total} %) "
                              f"{now - self._start:.1f} s")
            self.stream.flush()

    def __exit__(self, *exc) -> None:
        if self.enabled:
            self.stream.write("\n")
            self.stream.flush()
