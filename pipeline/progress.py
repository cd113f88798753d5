"""Progress display for long work (batch IK, benchmarks, big jobs): a one-line counter on a terminal,
silent when standard error is not a terminal (pipes, CI, notebooks, tests) or PIPELINE_PROGRESS=0; and a
notice while Numba compiles the kernels on first use on a machine (on a terminal and in notebooks)."""

from __future__ import annotations

import logging
import os
import sys
import time

from numba.core import event

#: Redraw at most this often [s].
REDRAW_INTERVAL = 0.2
#: What compiling takes on this machine kind for the first call that needs the most, the closed form's IK kernel
#: (each kernel compiles when first called; measured with an empty NUMBA_CACHE_DIR, ``bench job``: 15-18 s; FK
#: alone about 2 s); a burst of compiling that takes longer than COMPILE_REPORT_S says how long.
FIRST_COMPILE_S = 16
COMPILE_REPORT_S = 1.0

log = logging.getLogger(__name__)


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


class CompileNotice(event.Listener):
    """Says once per process, when Numba starts compiling (its disk cache misses: the first use on a machine,
    or after an upgrade), that it compiles once and about how long it takes, and after each burst of compiling
    longer than COMPILE_REPORT_S how long it took: on a terminal and in a notebook (``notice_enabled``), and
    to the log."""

    def __init__(self, stream=None):
        self.stream = stream
        self.depth, self.said, self.started = 0, False, 0.0

    def on_start(self, event) -> None:
        if self.depth == 0:
            self.started = time.perf_counter()
            if not self.said:
                self.said = True
                self._say(f"compiling the kinematics once for this machine (each kernel when first used, up to about "
                          f"{FIRST_COMPILE_S} s; later runs load them from the cache) ...")
        self.depth += 1

    def on_end(self, event) -> None:
        self.depth -= 1
        spent = time.perf_counter() - self.started
        if self.depth == 0 and spent > COMPILE_REPORT_S:
            self._say(f"compiled in {spent:.1f} s")

    def _say(self, text: str) -> None:
        log.info(text)
        stream = sys.stderr if self.stream is None else self.stream
        if notice_enabled(stream):
            stream.write(text + "\n")
            stream.flush()


def notice_enabled(stream) -> bool:
    """Progress on ``stream`` (a terminal), or in a running Jupyter kernel (its stderr is not a terminal but is
    shown under the cell)."""
    return progress_enabled(stream) or (os.environ.get("PIPELINE_PROGRESS", "1") != "0" and _in_jupyter_kernel())


def _in_jupyter_kernel() -> bool:
    """Whether this process is a Jupyter kernel running a notebook (IPython's shell there is ZMQInteractiveShell)."""
    shell = getattr(sys.modules.get("IPython"), "get_ipython", lambda: None)()
    return type(shell).__name__ == "ZMQInteractiveShell"


COMPILE_NOTICE = CompileNotice()
event.register("numba:compile", COMPILE_NOTICE)
