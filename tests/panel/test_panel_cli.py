"""``armctl view`` with a bus serves the control panel; ``--watch`` only follows the bus."""

from __future__ import annotations

import json

import pytest

from armctl.cli import main


def _run(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[int, dict, str]:
    code = main(list(argv))
    out, err = capsys.readouterr()
    return code, (json.loads(out) if out.strip().startswith("{") else {}), err


def test_view_on_the_simulated_bus_is_a_control_panel(capsys):
    code, data, err = _run(capsys, "view", "so101", "--sim", "--http-port", "0", "--duration",
                           "0.2", "--token", "abc", "--json")
    assert code == 0 and data["control"] is True and data["token"] is True
    assert data["bus_port"] == "sim" and data["url"].startswith("http://127.0.0.1:")
    assert "warning" not in err  # localhost: no warning


def test_watch_only_follows(capsys):
    code, data, _ = _run(capsys, "view", "so101", "--sim", "--watch", "--http-port", "0",
                         "--duration", "0.2", "--json")
    assert code == 0 and data["bus"] is True and "control" not in data


def test_exposing_the_panel_warns(capsys):
    code, _, err = _run(capsys, "view", "so101", "--sim", "--host", "0.0.0.0", "--http-port",
                        "0", "--duration", "0.2")
    assert code == 0
    assert "warning: --host 0.0.0.0" in err and "command the arm" in err and "--token" in err
