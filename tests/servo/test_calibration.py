"""Calibration on the simulated bus, with a simulated user moving the joints by hand."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from armctl.config.schema import ArmSpec
from armctl.errors import ConfigError, InputError, JointLimitError
from armctl.servo import ArmBus, Calibration, Calibrator, JointMapping, Register, SimulatedBus

pytestmark = pytest.mark.timeout(30)
TICK = 2 * math.pi / 4096


def _sweep(sim: SimulatedBus, cal: Calibrator, sid: int, ref: int, lo: int, hi: int) -> None:
    """The user moves one joint from the reference down to lo, up to hi, and back (raw ticks)."""
    path = [*range(ref, lo - 1, -150), *range(lo, hi + 1, 150), *range(hi, ref - 1, -150), ref]
    for t in path:
        sim.set_joint(sid, t % 4096)
        cal.sample()


# raw encoder ticks of the reference pose and the sweep, per servo id (Feetech arm)
REF = {1: 3900, 2: 1000, 3: 2048, 4: 2500, 5: 100, 6: 1000}
SWEEP = {1: (2900, 4900), 2: (300, 1800), 3: (1200, 3000), 4: (1700, 3300), 5: (-400, 600),
         6: (1000, 2900)}


def _calibrate_feetech(so_spec: ArmSpec) -> tuple[Calibration, SimulatedBus, ArmBus]:
    ab = ArmBus.from_spec(so_spec).open()
    sim = ab.simulator
    assert sim is not None
    cal = Calibrator(ab)
    cal.start()
    for sid, t in REF.items():
        sim.set_joint(sid, t)
    assert cal.capture_reference() == {j.name: REF[j.servo_id] for j in ab.mapping.joints}
    for sid, (lo, hi) in SWEEP.items():
        _sweep(sim, cal, sid, REF[sid], lo, hi)
    return cal.finish(), sim, ab


def test_feetech_calibration_moves_wrap_out_of_travel(so_spec: ArmSpec, tmp_path: Path) -> None:
    result, sim, ab = _calibrate_feetech(so_spec)
    try:
        wraps = {n: j.wrap_detected for n, j in result.joints.items()}
        assert wraps == {"shoulder_pan": True, "shoulder_lift": False, "elbow_flex": False,
                         "wrist_flex": False, "wrist_roll": True, "gripper": False}
        for name, jc in result.joints.items():
            servo = sim.servo(jc.servo_id)
            # Feetech: present = actual - offset; the offset is in the servo now
            assert servo.get(Register.HOMING_OFFSET) == jc.homing_offset
            assert jc.zero_tick == (REF[jc.servo_id] - jc.homing_offset) % 4096
            lo, hi = SWEEP[jc.servo_id]
            assert jc.max_tick - jc.min_tick == hi - lo
            mid = (jc.min_tick + jc.max_tick) / 2
            assert abs(mid - 2048) <= 1, name  # travel centred, clear of the wrap
            assert 0 <= jc.min_tick and jc.max_tick <= 4095
        mapping = JointMapping.from_spec(so_spec, result)
        np.testing.assert_allclose(mapping.from_ticks(sim.positions), 0.0, atol=1e-12)
        pan = mapping.joint("shoulder_pan")
        assert pan.lower == pytest.approx(-1000 * TICK) and pan.upper == pytest.approx(
            1000 * TICK)
        assert not any(j.wrap_inside() for j in mapping.joints)
    finally:
        ab.close()

    path = result.save(tmp_path / "so_sim.calibration.yaml")
    loaded = Calibration.load(path)
    assert loaded == result and loaded.hash == result.hash
    # a calibrated bus: the limits are the measured ones, the wrap is gone
    with ArmBus.from_spec(so_spec, loaded) as cab:
        np.testing.assert_allclose(cab.read_joints(), 0.0, atol=TICK)
        cab.set_torque(True)
        with pytest.raises(JointLimitError):
            cab.write_joints(np.array([1.0 * 1000 * TICK + 0.01, 0, 0, 0, 0, 0.0]))
        cab.write_joints(np.array([0.9 * 1000 * TICK, 0, 0, 0, 0, 0.0]))


def test_calibration_file_checks(so_spec: ArmSpec, tmp_path: Path) -> None:
    result, _, ab = _calibrate_feetech(so_spec)
    ab.close()
    path = result.save(tmp_path / "c.yaml")
    text = path.read_text()
    path.write_text(text.replace("zero_value: 0.0", "zero_value: 0.5", 1))
    with pytest.raises(ConfigError, match="edited"):
        Calibration.load(path)
    path.write_text(text.replace("armctl_calibration: 1", "armctl_calibration: 9"))
    with pytest.raises(ConfigError, match="version 9") as info:
        Calibration.load(path)
    assert ":2:" in str(info.value)


def test_unswept_joint_is_refused(so_spec: ArmSpec) -> None:
    with ArmBus.from_spec(so_spec) as ab:
        cal = Calibrator(ab)
        cal.start()
        cal.capture_reference()
        cal.sample()
        with pytest.raises(InputError, match="moved only 0 ticks"):
            cal.finish()


def test_dynamixel_large_shift_uses_extended_mode(dxl_spec: ArmSpec) -> None:
    with ArmBus.from_spec(dxl_spec) as ab:
        sim = ab.simulator
        assert sim is not None
        cal = Calibrator(ab, {"j2": 0.2})
        cal.start()
        sim.set_joint(14, 300)  # j4's reference near the wrap: centring needs > 1024 ticks
        ref = cal.capture_reference()
        sweeps = {11: (ref["j1"] - 3000, ref["j1"] + 3000), 12: (1000, 3000), 13: (1500, 2500),
                  14: (-500, 1100)}
        for sid, (lo, hi) in sweeps.items():
            r = ref[ab.mapping.joints[sid - 11].name]
            path = [*range(r, lo - 1, -150), *range(lo, hi + 1, 150), *range(hi, r, -150), r]
            for t in path:
                sim.set_joint(sid, t if sid == 11 else t % 4096)
                cal.sample()
        result = cal.finish()
        j4 = result.joints["j4"]
        assert j4.multi_turn and j4.wrap_detected and abs(j4.homing_offset) > 1024
        assert ab.servo_bus.read(14, Register.OPERATING_MODE) == 4
        assert result.joints["j1"].multi_turn and result.joints["j1"].homing_offset == 0
        mapping = JointMapping.from_spec(dxl_spec, result)
        q = mapping.from_ticks(sim.positions)
        np.testing.assert_allclose(q, [0.0, 0.2, 0.0, 0.0], atol=1e-12)
