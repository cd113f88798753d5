"""Progress display: drawn on a terminal, silent elsewhere."""

from __future__ import annotations

import io

from pipeline.progress import Progress


class FakeTerminal(io.StringIO):
    def isatty(self) -> bool:
        return True


def test_draws_on_a_terminal_and_ends_the_line(monkeypatch):
    monkeypatch.delenv("PIPELINE_PROGRESS", raising=False)
    stream = FakeTerminal()
    with Progress(3, "IK gp7", stream) as tick:
        for _ in range(3):
            tick()
    text = stream.getvalue()
    assert "IK gp7: 3/3 (100 %)" in text and text.endswith("\n")


def test_silent_when_not_a_terminal_or_switched_off(monkeypatch):
    stream = io.StringIO()
    with Progress(3, "IK", stream) as tick:
        tick()
    assert stream.getvalue() == ""
    monkeypatch.setenv("PIPELINE_PROGRESS", "0")
    terminal = FakeTerminal()
    with Progress(3, "IK", terminal) as tick:
        tick(3)
    assert terminal.getvalue() == ""


def test_numba_compiling_is_announced_once_on_a_terminal(monkeypatch):
    """A compile (a Numba cache miss) says so once, with how long compiling takes; silent off a terminal."""
    from numba import njit
    from numba.core import event

    from pipeline.progress import CompileNotice

    monkeypatch.delenv("PIPELINE_PROGRESS", raising=False)
    terminal, pipe = FakeTerminal(), io.StringIO()
    with event.install_listener("numba:compile", CompileNotice(terminal)), \
            event.install_listener("numba:compile", CompileNotice(pipe)):
        njit(lambda x: x + 1)(1)
        njit(lambda x: x * 2.0)(1.0)
    assert terminal.getvalue().count("compiling the kinematics once") == 1
    assert pipe.getvalue() == ""
