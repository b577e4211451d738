"""``armctl teach``: Ctrl-C during a continuous recording ends the recording too."""

from __future__ import annotations

import sys
import threading
from typing import Any

import pytest

from armctl.cli._teach_loop import teach_loop

pytestmark = pytest.mark.timeout(30)


class RecordingSession:
    """Records (in the worker thread) until told to stop; says when it has stopped."""

    def __init__(self) -> None:
        self.recording = threading.Event()
        self.ended = threading.Event()

    def check_recording(self, rate: float, duration: float | None) -> None:
        pass

    def record_continuous(self, rate: float, stop: threading.Event,
                          duration: float | None = None) -> int:
        self.recording.set()
        stop.wait(10.0)  # a recording that nobody stops runs on (to the test's timeout)
        self.ended.set()
        return 0


class CtrlCWhileWaiting:
    """stdin: ``c 20`` (record at 20 Hz until Enter), then Ctrl-C instead of Enter."""

    def __init__(self, session: RecordingSession):
        self.session = session
        self.lines = ["c 20\n"]

    def readline(self) -> str:
        if self.lines:
            return self.lines.pop(0)
        assert self.session.recording.wait(5.0)  # the worker is recording now
        raise KeyboardInterrupt


def test_ctrl_c_while_recording_stops_the_recording(monkeypatch: pytest.MonkeyPatch) -> None:
    session = RecordingSession()
    monkeypatch.setattr(sys, "stdin", CtrlCWhileWaiting(session))
    said: list[str] = []
    robot: Any = None  # the recording command does not use it
    with pytest.raises(KeyboardInterrupt):
        teach_loop(session, robot, said.append, said.append)
    assert session.ended.is_set()  # stopped and joined before the interrupt went on
    assert any("recording at 20 Hz" in s for s in said)
