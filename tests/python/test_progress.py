# SPDX-License-Identifier: MIT
"""Progress of long runs (mstc.report.progress): a bar with an ETA on a
terminal, plain lines otherwise and in CI."""

from __future__ import annotations

import io

import pytest

from mstc.report.progress import ProgressBar

# ------------------------------------------------------------- progress


class Tty(io.StringIO):
    def isatty(self) -> bool:
        return True


def test_progress_is_plain_lines_every_tenth_when_not_a_terminal(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.delenv("CI", raising=False)
    now = [0.0]
    stream = io.StringIO()
    p = ProgressBar(1000, "replay", stream=stream, clock=lambda: now[0])
    for done in range(0, 1001, 10):
        now[0] = done / 100  # 10 s in all
        p.update(done)
    p.close()
    lines = stream.getvalue().splitlines()
    # Nothing within the first second (before 10 %), then one line per tenth to 90 %.
    assert [line.split(":")[1].split("%")[0].strip() for line in lines[:-1]] == [
        str(n) for n in range(10, 100, 10)
    ]
    assert lines[1] == "replay: 20% (200/1,000 frames), 00:02 elapsed, 00:08 left"
    assert lines[-1] == "replay: done in 00:10"
    assert "\r" not in stream.getvalue()


def test_progress_is_a_bar_with_eta_on_a_terminal(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv("CI", raising=False)
    now = [0.0]
    stream = Tty()
    p = ProgressBar(400, "replay", stream=stream, clock=lambda: now[0])
    now[0] = 2.0
    p.update(100)
    text = stream.getvalue()
    assert text.startswith("\rreplay [#######---------------------]  25% 100/400 frames ETA 00:06")
    assert "\n" not in text  # redrawn in place
    p.close()
    # Cleared: close wrote blanks over the bar, between carriage returns.
    closing = stream.getvalue()[len(text) :]
    assert closing.startswith("\r") and closing.endswith("\r") and not closing.strip()


def test_progress_is_plain_in_ci_even_on_a_terminal(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("CI", "true")
    now = [5.0]
    stream = Tty()
    p = ProgressBar(10, "replay", stream=stream, clock=lambda: now[0])
    now[0] = 7.0
    p.update(5)
    assert stream.getvalue() == "replay: 50% (5/10 frames), 00:02 elapsed, 00:02 left\n"


def test_short_or_quiet_runs_show_no_progress() -> None:
    stream = Tty()
    p = ProgressBar(10, "replay", stream=stream, clock=lambda: 0.5, plain=False)
    p.update(5)
    p.close()
    quiet = ProgressBar(10, "replay", stream=stream, clock=lambda: 9.0, enabled=False)
    quiet.update(5)
    quiet.close()
    assert stream.getvalue() == ""
