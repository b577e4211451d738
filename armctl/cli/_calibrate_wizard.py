"""The steps of ``armctl calibrate``: prompts, and Enter presses that drive the calibrator."""

from __future__ import annotations

import select
import sys
from typing import TYPE_CHECKING, Any

from armctl.errors import InputError

if TYPE_CHECKING:
    from armctl.servo.calibrate import Calibrator


def wait_enter(prompt: str, while_waiting: Any = None, period: float = 0.02) -> None:
    """Print ``prompt`` and wait for Enter, calling ``while_waiting`` every ``period`` [s].

    Raises:
        InputError: When the input is closed (end of file) instead: the wizard needs Enter
            presses, so nothing is measured or written.
    """
    print(prompt, flush=True)
    while True:
        if while_waiting is not None:
            while_waiting()
        ready, _, _ = select.select([sys.stdin], [], [], period)
        if ready:
            if not sys.stdin.readline():
                raise InputError("the input was closed (end of file) while the calibration "
                                 "waited for Enter; nothing was written. Run 'armctl "
                                 "calibrate' in a terminal and press Enter at each step")
            return


def run_wizard(cal: Calibrator, reference: str) -> None:
    """Guide the user through a calibration: reference pose, then the range sweep.

    Call ``cal.finish()`` afterwards for the result.

    Args:
        cal: A calibrator on the open bus (not started).
        reference: The reference pose's name, for the prompt ('zero' or a pose of the arm).
    """
    cal.start()
    wait_enter("Torque is off. Move the arm to the reference pose "
               f"({reference}) and press Enter.")
    cal.capture_reference()
    wait_enter("Move every joint slowly through its full range, then back to the "
               "reference pose, and press Enter.", cal.sample)
