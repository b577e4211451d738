"""``JointState.load`` is a fraction of the stall torque on every model; ``current`` is in amperes.

A known external torque on each simulated servo (``SimServo.set_load``) must read back, once the
servo holds against it, as that torque over the model's stall torque, and on current-sensing
models as the current the motor needs for it (``I = T * I_stall / T_stall``: torque proportional
to current). The figures below are transcribed here from the makers' specifications, not read
from armctl's tables.
"""

from __future__ import annotations

import json
import math
from dataclasses import replace

import numpy as np
import pytest

from armctl.cli import main
from armctl.clock import SimulatedClock
from armctl.config import load_spec
from armctl.config.schema import ArmSpec
from armctl.servo import ArmBus
from armctl.servo.load_units import load_scale

pytestmark = pytest.mark.timeout(60)

#: model -> (stall torque [N m], stall current [A], unit of the address-126 / Present_Load
#: register: [A] per count, or None when it reports the load in 0.1 %). ROBOTIS e-Manual
#: specifications and control tables of each X-series model (XL330: Present Current 1 mA;
#: XM430/XM540: about 2.69 mA; XL430: Present Load 0.1 %); STS3215 product specification
#: (19.5 kg cm at 7.4 V, stall current 2.7 A as resellers list it) and Feetech's memory table
#: (Present_Load 0.1 %).
MAKER: dict[str, tuple[float, float, float | None]] = {
    "xl330-m077": (0.215, 1.47, 0.001),
    "xl330-m288": (0.52, 1.47, 0.001),
    "xl430-w250": (1.4, 1.3, None),
    "xm430-w350": (4.1, 2.3, 0.00269),
    "xm540-w270": (10.6, 4.4, 0.00269),
    "sts3215": (1.91, 2.7, None),
}


def _xm540_arm() -> ArmSpec:
    """The UR5e config driven by XM540-W270 servos (no bundled arm uses them)."""
    spec = load_spec("ur5e")
    assert spec.bus is not None
    servos = tuple(replace(s, model="xm540-w270") for s in spec.bus.servos)
    return replace(spec, bus=replace(spec.bus, servos=servos))


#: Arms that together carry every model (the OMX gripper joint is reversed).
ARMS = {"so101": lambda: load_spec("so101"), "koch_follower": lambda: load_spec("koch_follower"),
        "koch_leader": lambda: load_spec("koch_leader"), "omx": lambda: load_spec("omx"),
        "xm540": _xm540_arm}


def test_every_model_is_covered() -> None:
    models = set()
    for make in ARMS.values():
        spec = make()
        assert spec.bus is not None
        models |= {s.model for s in spec.bus.servos}
    assert models == set(MAKER)


@pytest.mark.parametrize("model", sorted(MAKER))
def test_the_register_unit_converts_to_the_makers_figures(model: str) -> None:
    _, stall, amps = MAKER[model]
    scale = load_scale(model)
    if amps is None:
        assert scale.fraction == pytest.approx(0.001) and math.isnan(scale.amps)
        assert not scale.current_sensing
    else:
        assert scale.amps == pytest.approx(amps) and scale.current_sensing
        assert scale.fraction == pytest.approx(amps / stall)


@pytest.mark.parametrize("arm", sorted(ARMS))
def test_a_known_external_torque_reads_back_as_fraction_and_amperes(arm: str) -> None:
    clock = SimulatedClock()
    spec = ARMS[arm]()
    with ArmBus.from_spec(spec, clock=clock) as ab:
        sim = ab.simulator
        assert sim is not None
        joints = ab.mapping.joints
        want_fraction, want_amps = [], []
        for k, j in enumerate(joints):
            torque, stall, amps = MAKER[j.model]
            share = (0.25, -0.4, 0.55)[k % 3]  # of the stall torque, both ways
            # the load pushes against the encoder's positive direction: the servo holds it
            # with a positive torque of its own (in the servo's sense; the joint's sense
            # is the servo's times the mapping's direction)
            sim.servo(j.servo_id).set_load(share * torque)
            want_fraction.append(j.direction * share)
            want_amps.append(j.direction * share * stall if amps is not None else math.nan)
        ab.set_torque(True)
        clock.advance(1.5)  # the position loops settle against the loads
        st = ab.read_state()
        for i, j in enumerate(joints):
            where = f"{arm} {j.name} ({j.model}, direction {j.direction})"
            # the steady position error's P torque balances the load; dry friction (about
            # 1 % of the stall torque) and the register's resolution are the tolerance
            assert st.load[i] == pytest.approx(want_fraction[i], abs=0.02), where
            if math.isnan(want_amps[i]):
                assert math.isnan(st.current[i]), where
            else:
                assert st.current[i] == pytest.approx(want_amps[i], rel=0.05), where
                assert st.current[i] / st.load[i] == pytest.approx(MAKER[j.model][1], rel=1e-9)
        ab.set_torque(False)
        clock.advance(0.1)
        off = ab.read_state()
        assert np.all(off.load == 0.0)  # the bridge is off: no current, no torque
        assert all(c == 0.0 or (math.isnan(c) and MAKER[j.model][2] is None)
                   for c, j in zip(off.current, joints, strict=True))


def test_a_reversed_joint_reports_the_load_in_the_joints_sense() -> None:
    spec = load_spec("so101")
    assert spec.bus is not None
    flipped = tuple(replace(s, direction=-s.direction) for s in spec.bus.servos)
    loads = []
    for arm in (spec, replace(spec, bus=replace(spec.bus, servos=flipped))):
        clock = SimulatedClock()
        with ArmBus.from_spec(arm, clock=clock) as ab:
            assert ab.simulator is not None
            ab.simulator.servo(ab.mapping.joint("elbow_flex").servo_id).set_load(0.5)
            ab.set_torque(True)
            clock.advance(1.0)
            loads.append(float(ab.read_state().load[ab.joint_names.index("elbow_flex")]))
    assert loads[0] == pytest.approx(0.5 / 1.91, abs=0.02) and loads[1] == pytest.approx(
        -loads[0], abs=0.01)


def test_status_shows_load_and_current(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["status", "koch_follower", "--once", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    spec = load_spec("koch_follower")
    assert spec.bus is not None
    models = {s.joint: s.model for s in spec.bus.servos}
    assert {j["joint"] for j in out["joints"]} == set(models)
    for j in out["joints"]:
        assert j["load"] == 0.0  # torque off: no current
        if models[j["joint"]] == "xl430-w250":  # no current sensing
            assert j["current"] is None
        else:
            assert j["current"] == 0.0
    assert main(["status", "so101", "--once"]) == 0
    text = capsys.readouterr().out
    assert "load [% stall]" in text and "current [A]" in text
