"""tools/fit_motor_model.py recovers known motor parameters from a simulated step response.

The recording is produced here, by the simulator driven as a host would (goal writes and
present position/current reads at 100 Hz), with motor parameters that differ from the model's
defaults; the fitter starts from the defaults and must find the ones that made the recording.
"""

from __future__ import annotations

import dataclasses
import importlib.util
import json
from pathlib import Path

import pytest
from armctl_testpaths import REPO
from sim_servo_helpers import Bench

from armctl.servo_tables import Register
from armctl.servo_tables.motors import motor_for

R = Register


def _tool():  # type: ignore[no-untyped-def]
    spec = importlib.util.spec_from_file_location("fit_motor_model",
                                                  REPO / "tools" / "fit_motor_model.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _record(path: Path, model: str, **changes: float) -> None:
    """Write a step response of ``model`` with motor parameters ``changes`` to ``path``."""
    truth = dataclasses.replace(motor_for(model), **changes)
    b = Bench(model)
    b.servo.use_motor(truth)
    b.write(R.TORQUE_ENABLE, 1)
    rows = ["time,goal,position,current"]
    goal = None
    for k in range(80):  # 0.8 s at 100 Hz: a step of 600 ticks, then back by 20 at 0.5 s
        if k:
            b.clock.advance(0.01)
        want = 2648 if k < 50 else 2628
        if want != goal:
            b.write(R.GOAL_POSITION, want)
            goal = want
        amps = b.read(R.PRESENT_LOAD) * 0.00269  # Present Current, about 2.69 mA
        rows.append(f"{k * 0.01:.2f},{goal},{b.read(R.PRESENT_POSITION)},{amps:.5f}")
    path.write_text("\n".join(rows) + "\n", encoding="utf-8")


def test_fitter_recovers_the_parameters_of_a_simulated_step_response(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    base = motor_for("xm430-w350")
    truth = {"mechanical_time_constant": 1.6 * base.mechanical_time_constant,
             "no_load_speed": 0.85 * base.no_load_speed, "stall_current": 0.8 * base.stall_current}
    csv = tmp_path / "step.csv"
    _record(csv, "xm430-w350", **truth)
    assert _tool().main([str(csv), "--model", "xm430-w350"]) == 0
    out = json.loads(capsys.readouterr().out)
    for name, value in truth.items():
        assert out[name] == pytest.approx(value, rel=0.01), name
        assert abs(out["datasheet"][name] - value) > 0.1 * value  # it did have to move
    assert out["residual"] < 1e-6


def test_fitter_names_the_line_of_a_bad_csv(tmp_path: Path,
                                            capsys: pytest.CaptureFixture[str]) -> None:
    csv = tmp_path / "bad.csv"
    csv.write_text("time,goal,position,current\n0,2048,2048,0\n0.01,2648,x,0\n",
                   encoding="utf-8")
    assert _tool().main([str(csv), "--model", "xm430-w350"]) == 2
    err = capsys.readouterr().err
    assert f"{csv}:3" in err and "expected numbers" in err
