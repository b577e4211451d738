"""Errors of the control panel: a command from a tab that may not command, or at a bad time."""

from __future__ import annotations

from armctl.errors import InputError

__all__ = ["ControlDenied", "PanelBusy"]


class ControlDenied(InputError):
    """A command from a tab that does not have control (or a wrong token).

    ``details``: ``client`` (who asked), ``controller`` (who has control, or ``None``).
    """

    def __init__(self, message: str, client: str, controller: str | None):
        super().__init__(message, {"client": client, "controller": controller})


class PanelBusy(InputError):
    """A command that needs the arm at rest while a motion runs (Stop is always accepted).

    ``details``: ``activity`` (what runs).
    """

    def __init__(self, message: str, activity: str):
        super().__init__(message, {"activity": activity})
