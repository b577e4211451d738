"""The web control panel: what ``armctl view`` serves when it owns the arm's bus.

:class:`ControlPanel` (:mod:`armctl.panel.state`) is the server-side state that every browser
tab shares: who commands, the previewed target and its ghost configuration or the reason it is
refused, the running motion, the keyframe list. Every command goes through the
:class:`~armctl.robot.Robot` (its IK, effective limits, collision checks, stop and motion
control), so the page can send nothing that the command line would refuse.
:class:`PanelPage` (:mod:`armctl.panel.page`) binds it to a viser page (extra ``view``).
"""

from armctl.panel.errors import ControlDenied, PanelBusy
from armctl.panel.state import ControlPanel, Phase, Preview, PreviewKind

__all__ = ["ControlDenied", "ControlPanel", "PanelBusy", "Phase", "Preview", "PreviewKind"]
