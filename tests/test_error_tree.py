"""One exception tree: every armctl exception is an ArmctlError with JSON-safe ``details``."""

from __future__ import annotations

import dataclasses
import errno
import importlib
import json
import math
import pkgutil
import signal
from enum import Enum
from pathlib import Path
from typing import Any

import numpy as np
import pytest

import armctl
from armctl.arm import load_arm
from armctl.cli import main
from armctl.collision.contact import Contact, ContactKind
from armctl.errors import ArmctlError, ConfigError, KeyPath, UnknownNameError, json_safe
from armctl.ik import PositionGoal
from armctl.ik.errors import IKFailedError
from armctl.robot.errors import MotionStopped, SignalInterrupt, StopReason
from armctl.servo.errors import PortError, port_error

#: Exceptions outside the tree on purpose, with the reason (also in armctl/errors.py).
OUTSIDE_THE_TREE = {
    SignalInterrupt: "a KeyboardInterrupt, so that SIGTERM and SIGHUP pass 'except Exception' "
                     "and end a command the way Ctrl-C does",
}


def _armctl_modules() -> list[str]:
    names = [m.name for m in pkgutil.walk_packages(armctl.__path__, "armctl.")
             if not m.name.endswith("__main__")]  # __main__ would run the command line
    for name in names:
        importlib.import_module(name)
    return names


def _subclasses(root: type) -> set[type]:
    out: set[type] = set()
    todo = [root]
    while todo:
        for sub in todo.pop().__subclasses__():
            if sub not in out:
                out.add(sub)
                todo.append(sub)
    return out


def _armctl_exceptions() -> list[type[BaseException]]:
    _armctl_modules()
    found = [c for c in _subclasses(BaseException) if c.__module__.startswith("armctl.")]
    return sorted(found, key=lambda c: f"{c.__module__}.{c.__qualname__}")


def test_every_armctl_exception_derives_from_armctl_error() -> None:
    classes = _armctl_exceptions()
    assert len(classes) > 30  # the walk found the tree (servo, robot, ik, motion, render, ...)
    outside = [c for c in classes if not issubclass(c, ArmctlError)]
    assert outside == list(OUTSIDE_THE_TREE), (
        "exceptions outside the armctl tree: derive them from armctl.errors.ArmctlError (or a "
        f"subclass): {[f'{c.__module__}.{c.__qualname__}' for c in outside]}")
    assert issubclass(SignalInterrupt, KeyboardInterrupt)
    assert not issubclass(SignalInterrupt, Exception)


def test_details_live_on_the_base_class_only() -> None:
    for cls in _armctl_exceptions():
        if issubclass(cls, ArmctlError):
            # an attribute or property of the class would hide the instance's details
            assert all("details" not in vars(c) for c in cls.__mro__), cls


def test_no_armctl_class_named_error_is_a_record() -> None:
    # IK results hold GoalResidual and ConstraintViolation records; "...Error" names exceptions
    records = []
    for name in _armctl_modules():
        module = importlib.import_module(name)
        for obj in vars(module).values():
            if (isinstance(obj, type) and obj.__module__ == name and obj.__name__.endswith("Error")
                    and not issubclass(obj, BaseException)):
                records.append(f"{name}.{obj.__name__}")
    assert records == []


def _result() -> Any:
    arm = load_arm("so101")
    res = arm.ik(PositionGoal([2.0, 0.0, 0.2]), solver="dls")
    assert not res.success
    return res


#: Constructor arguments of every exception class that defines ``__init__`` (keyed by it).
SAMPLES: dict[str, tuple[Any, ...]] = {
    "armctl.errors.ArmctlError": ("something went wrong",),
    "armctl.panel.errors.ControlDenied": ("tab 2 has control", "tab 1", "tab 2"),
    "armctl.panel.errors.PanelBusy": ("cannot preview while a move runs", "moving"),
    "armctl.collision.errors.CollisionError": (
        "move to pose", Contact(ContactKind.SCENE, "gripper", "table", -0.01, 0.005,
                                np.array([0.1, 0.2]), 0.5, 3, -0.02, 0.7),
        ("shoulder", "elbow"), "choose another goal"),
    "armctl.collision.errors.MissingExtraError": ("exact distances", "coal", "collision"),
    "armctl.motion.errors.DetourError": ("no path found", 1.0, 1.2, "RRT-Connect (ompl)",
                                         "give it more time"),
    "armctl.errors.ConfigError": ("lower limit above upper",
                                  KeyPath(Path("arm.yaml"), ("joints", 2, "limits"), 14, "elbow"),
                                  "swap them"),
    "armctl.errors.UnknownNameError": ("joint", "elbw", ["elbow_flex", "wrist"], "arm 'a'"),
    "armctl.errors.JointLimitError": ("elbow", 2.0, -1.0, np.float64(1.0), "goal"),
    "armctl.ik.analytic.errors.NoDecompositionError": ("no closed form", "use dls"),
    "armctl.ik.errors.IKFailedError": (None, "cannot reach", None),  # result filled in below
    "armctl.ik.errors.UnsupportedGoalError": ("ccd cannot solve look-at goals", "ccd"),
    "armctl.kinematics.linkshapes.MeshLoadError": (Path("m.stl"), "base", "missing",
                                                   Path("arm.yaml")),
    "armctl.motion.errors.LimitViolation": ("elbow", "velocity", np.float64(3.0), 2.0, 0.5,
                                            "slow down", "rad"),
    "armctl.motion.errors.PathError": (0.5, "IK failed", "elbow"),
    "armctl.render.errors.OutputError": (Path("out/x.png"), "no such folder", "create it"),
    "armctl.robot.errors.JointValueError": ("elbow", 2.0, -1.0, 1.0, "elbow: 114.6 deg ..."),
    "armctl.robot.errors.MotionStopped": (StopReason.TRACKING, "tracking error", "elbow", 3,
                                          np.zeros(6), 0.25, None),
    "armctl.robot.executor._Abort": (StopReason.LOST_SERVO, "servo 3 stopped answering",
                                     "elbow", 3),
    "armctl.servo.errors.ServoBusError": ("no reply", "/dev/ttyACM0", 3, "Present_Position",
                                          None, "check the cable"),
}


def _owner(cls: type) -> str:
    """The class whose ``__init__`` builds instances of ``cls``."""
    for c in cls.__mro__:
        if "__init__" in vars(c):
            return f"{c.__module__}.{c.__qualname__}"
    raise AssertionError(cls)


def test_every_error_class_has_json_safe_details() -> None:
    res = _result()
    for cls in _armctl_exceptions():
        if not issubclass(cls, ArmctlError):
            continue
        owner = _owner(cls)
        assert owner in SAMPLES, f"add sample constructor arguments for {owner} to SAMPLES"
        args = SAMPLES[owner]
        if owner == "armctl.ik.errors.IKFailedError":
            args = (res, "cannot reach", {"closest_q": res.q, "status": res.status})
        exc = cls(*args)
        assert isinstance(exc.details, dict), cls
        assert all(isinstance(k, str) for k in exc.details), cls
        json.dumps(exc.details, allow_nan=False)
        assert str(exc) and exc.exit_code in (1, 2, 3, 4, 5), cls


def test_details_carry_the_facts() -> None:
    where = KeyPath(Path("arm.yaml"), ("joints", 2, "limits", "upper"), 14, "elbow")
    assert ConfigError("too big", where, "make it smaller").details == {
        "problem": "too big", "file": "arm.yaml", "line": 14,
        "key": "joints[2] (elbow).limits.upper", "fix": "make it smaller"}
    err = UnknownNameError("joint", "gripr", ["shoulder_pan", "gripper"])
    assert err.details["suggestion"] == "gripper" and err.details["valid"] == ["shoulder_pan",
                                                                               "gripper"]
    port = port_error("/dev/ttyNOPE", FileNotFoundError(errno.ENOENT, "No such file"))
    assert isinstance(port, PortError)
    assert port.details == {"port": "/dev/ttyNOPE", "servo_id": None, "register": None,
                            "answer": None, "problem": "no such port"}


def test_raised_errors_serialise(tmp_path: Path) -> None:
    arm = load_arm("so101")
    raised: list[ArmctlError] = []
    for action in (lambda: arm.fk(np.zeros(arm.dof), "nope"),
                   lambda: arm.check_limits(np.full(arm.dof, 9.0), "a test"),
                   lambda: load_arm(tmp_path / "missing.yaml")):
        with pytest.raises(ArmctlError) as info:
            action()
        raised.append(info.value)
    assert [type(e).__name__ for e in raised] == ["UnknownNameError", "JointLimitError",
                                                  "ConfigError"]
    assert raised[1].details["value"] == 9.0 and raised[2].details["file"].endswith(
        "missing.yaml")
    stop = MotionStopped(StopReason.USER, "stopped by SIGINT", time=0.5, signum=signal.SIGINT)
    stop.locate({"elbow": np.float64(0.5)}, np.array([0.1, 0.2, 0.3]), np.zeros(3))
    raised.append(stop)
    res = _result()
    raised.append(IKFailedError(res, "cannot reach", {
        "closest_q": res.q, "closest_xyz": arm.fk(res.q)[:3, 3], "status": res.status}))
    for exc in raised:
        text = json.dumps(exc.details, allow_nan=False)
        assert json.loads(text) == exc.details
    assert stop.details["stopped_at"] == {"joints": {"elbow": 0.5}, "xyz": [0.1, 0.2, 0.3],
                                          "rpy": [0.0, 0.0, 0.0]}
    assert stop.details["signal"] == "SIGINT"
    assert raised[-1].details["status"] == res.status.value


def test_json_safe() -> None:
    class Colour(Enum):
        RED = "red"

    @dataclasses.dataclass
    class Thing:
        x: int

    value = {"a": np.array([[1.0, math.nan], [math.inf, -math.inf]]), 2: (np.int64(3), True),
             "e": Colour.RED, "p": Path("x/y.yaml"), "b": np.bool_(False), "t": Thing(1),
             "n": None}
    assert json_safe(value) == {"a": [[1.0, None], ["inf", "-inf"]], "2": [3, True], "e": "red",
                                "p": "x/y.yaml", "b": False, "t": str(Thing(1)), "n": None}
    json.dumps(json_safe(value), allow_nan=False)


def test_cli_json_error_carries_details(capsys: pytest.CaptureFixture[str]) -> None:
    code = main(["fk", "so101", *["0"] * 6, "--frame", "l22", "--json"])
    out = json.loads(capsys.readouterr().out)
    assert code == 2 and out["ok"] is False
    error = out["error"]
    assert error["type"] == "UnknownNameError"
    assert error["details"]["name"] == "l22" and "tcp" in error["details"]["valid"]
    # an error without facts of its own still has details (empty)
    code = main(["fk", "so101", "0", "--json"])
    error = json.loads(capsys.readouterr().out)["error"]
    assert code == 2 and error["type"] == "InputError" and error["details"] == {}
