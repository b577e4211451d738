"""Check the simulated servo bus with LeRobot's motor buses, robots and teleoperators.

LeRobot (the `lerobot` package, Python >= 3.12) is not a dependency of armctl: this script runs
in a separate environment that has it, while `armctl sim` runs from armctl's own environment.
It starts `armctl sim --json CONFIG` (one process per arm), opens the printed pseudo-terminal
with LeRobot's `FeetechMotorsBus` / `DynamixelMotorsBus` and drives them through LeRobot's own
flows, then runs LeRobot's follower/leader classes (SO-101, Koch) on two simulators at once:

- bus level, per arm: `scan_port`, `broadcast_ping`, `connect` (handshake: ping and model
  number check, plus the firmware check on Feetech), `ping`, `read` and `sync_read` of every
  register of LeRobot's control table for the model, `write` of every writable register (its
  own value, then a changed value read back and restored), writes to read-only registers and
  to EEPROM with torque on (refused as the servo does), `configure_motors`, `read_calibration`
  / `set_half_turn_homings` / `write_calibration` / `is_calibrated` / `reset_calibration`,
  `disable_torque` / `enable_torque`, Operating Mode (every mode LeRobot lists for the model)
  with motion in it, `sync_write` of Goal_Position watched through Present_Position (with
  Moving, Moving_Status, Present_Velocity, Present_Current/Load, Realtime_Tick on the way),
  Drive Mode reverse, `setup_motor` (new id and baud rate, as `lerobot-setup-motors` does), 200
  reads for lost replies and reply time, `disconnect`;
- robot level, per follower/leader pair: `connect()` running the interactive `calibrate()`
  (prompts answered, the joints hand-guided through the simulator's console while
  `record_ranges_of_motion` samples them), reconnect with the saved calibration file
  (`connect(calibrate=False)`, `is_calibrated`), `get_observation`, `send_action`, a
  teleoperation loop leader -> follower of `--steps` steps with the leader hand-guided, whose
  frames (observation + action per step, as a recording stores them) are checked and written
  out, then `lerobot-calibrate` (its `main()`) for the follower and the leader.

Every step is recorded as PASS / FAIL / SKIP / INFO with LeRobot's exact error text; `--report FILE`
writes the table as Markdown, `--json FILE` as JSON. Exit status 0 when nothing failed, 1
otherwise.

Setting up the side environment (no CUDA, no torch):

    python3.12 -m venv lerobot_env
    lerobot_env/bin/pip install --no-deps lerobot
    lerobot_env/bin/pip install draccus deepdiff tqdm pyserial dynamixel-sdk feetech-servo-sdk \\
        "numpy<2.3" termcolor "packaging<26" "huggingface-hub>=1.6,<2" \\
        "opencv-python-headless<4.14" "setuptools<82"

(OpenCV only because `lerobot-calibrate` imports LeRobot's camera configs.)

LeRobot's `lerobot.utils` imports torch at module level only for device helpers that the
motor buses and robots never call; when torch is not installed this script puts a small stand-in
module (`torch.device`, `torch.dtype`, `cuda/xpu/backends.mps.is_available() -> False`) in
`sys.modules` before importing LeRobot. Nothing else of LeRobot is replaced or patched, except
the console: `input()` prompts and LeRobot's `enter_pressed()` are answered by this script.

Usage (armctl's own environment provides `armctl`):

    lerobot_env/bin/python tools/lerobot_interop.py --armctl /path/to/venv/bin/armctl \\
        [--feetech so101 so101_leader] [--dynamixel koch_follower koch_leader omx wx250s] \\
        [--pairs so101 koch] [--steps 300] [--wire-timing] [--report FILE.md] [--json FILE.json]
        [--frames DIR]

An arm that this armctl does not bundle is reported SKIP.
"""

from __future__ import annotations

import argparse
import builtins
import contextlib
import io
import json
import logging
import math
import queue
import re
import shlex
import shutil
import subprocess
import sys
import tempfile
import threading
import time
import types
from collections.abc import Callable, Iterator
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

# --------------------------------------------------------------------------------------------
# torch stand-in (only when torch is absent)


def _install_torch_stand_in() -> bool:
    """Put a minimal `torch` module in sys.modules if torch is not installed; True if done."""
    try:
        import torch  # noqa: F401
    except ImportError:
        pass
    else:
        return False

    class _Unavailable:
        @staticmethod
        def is_available() -> bool:
            return False

    class _Device:
        def __init__(self, kind: str = "cpu", *_: object) -> None:
            self.type = str(kind).split(":")[0]

        def __repr__(self) -> str:
            return f"device(type={self.type!r})"

    class _Dtype:
        pass

    stand_in = types.ModuleType("torch")
    stand_in.__dict__.update(
        device=_Device, dtype=_Dtype, Tensor=type("Tensor", (), {}), float32=_Dtype(),
        float64=_Dtype(), float16=_Dtype(), bfloat16=_Dtype(), cuda=_Unavailable(),
        xpu=_Unavailable(), backends=types.SimpleNamespace(mps=_Unavailable()),
        __version__="0.0-stand-in",
    )
    sys.modules["torch"] = stand_in
    return True


TORCH_STAND_IN = _install_torch_stand_in()

from lerobot.motors import Motor, MotorCalibration, MotorNormMode  # noqa: E402
from lerobot.motors import motors_bus as lr_motors_bus  # noqa: E402
from lerobot.motors.dynamixel import DynamixelMotorsBus  # noqa: E402
from lerobot.motors.dynamixel import OperatingMode as DxlMode  # noqa: E402
from lerobot.motors.dynamixel.tables import MODEL_OPERATING_MODES  # noqa: E402
from lerobot.motors.feetech import FeetechMotorsBus  # noqa: E402
from lerobot.motors.feetech import OperatingMode as FtMode  # noqa: E402
from lerobot.motors.motors_bus import get_ctrl_table  # noqa: E402

log = logging.getLogger("lerobot_interop")

# Registers the makers' tables mark read-only (ROBOTIS e-Manual X-series control tables;
# Feetech STS3215 memory table).
DXL_READ_ONLY = {
    "Model_Number", "Model_Information", "Firmware_Version", "Registered_Instruction",
    "Hardware_Error_Status", "Realtime_Tick", "Moving", "Moving_Status", "Present_PWM",
    "Present_Current", "Present_Velocity", "Present_Position", "Velocity_Trajectory",
    "Position_Trajectory", "Present_Input_Voltage", "Present_Temperature",
}
FT_READ_ONLY = {
    "Firmware_Major_Version", "Firmware_Minor_Version", "Model_Number", "Present_Position",
    "Present_Velocity", "Present_Load", "Present_Voltage", "Present_Temperature", "Status",
    "Moving", "Present_Current", "Goal_Position_2",
}
# Items of LeRobot's X-series table that the maker's present tables do not have for a model
# (ROBOTIS e-Manual: Acceleration Limit (40) was removed from every X-series table; the XL430-W250
# measures no current, so it has no Current Limit (38) or Goal Current (102)). A write to them is
# expected to be refused; they are reported, not failed.
NOT_IN_MAKER_TABLE = {
    "xl330-m077": {"Acceleration_Limit"}, "xl330-m288": {"Acceleration_Limit"},
    "xl430-w250": {"Acceleration_Limit", "Current_Limit", "Goal_Current"},
    "xm430-w350": {"Acceleration_Limit"}, "xm540-w270": {"Acceleration_Limit"},
}
# Writable registers not given a changed value (it would cut the line or change the flow under
# test); they are still written with their own value.
NO_CHANGE = {
    "ID", "Baud_Rate", "Protocol_Type", "Status_Return_Level", "Response_Status_Level",
    "Torque_Enable", "Lock", "Operating_Mode",
}
# Registers whose value moves by itself (read twice they may differ).
LIVE = {
    "Present_Position", "Present_Velocity", "Present_Load", "Present_Current", "Present_PWM",
    "Present_Voltage", "Present_Input_Voltage", "Present_Temperature", "Realtime_Tick",
    "Velocity_Trajectory", "Position_Trajectory", "Moving", "Moving_Status", "Status",
}


# --------------------------------------------------------------------------------------------
# results


@dataclass
class Step:
    """One checked step."""

    arm: str
    model: str
    flow: str
    status: str  # PASS, FAIL, SKIP, INFO
    detail: str = ""


class Recorder:
    """Collects steps and prints them as they come."""

    def __init__(self) -> None:
        self.steps: list[Step] = []

    def add(self, arm: str, model: str, flow: str, status: str, detail: str = "") -> None:
        step = Step(arm, model, flow, status, detail.strip())
        self.steps.append(step)
        line = f"[{status}] {arm} {model} {flow}"
        print(line + (f": {step.detail}" if step.detail else ""), flush=True)

    def check(self, arm: str, model: str, flow: str, ok: bool, detail: str = "") -> bool:
        self.add(arm, model, flow, "PASS" if ok else "FAIL", detail)
        return ok

    @contextlib.contextmanager
    def guard(self, arm: str, model: str, flow: str, detail: str = "") -> Iterator[None]:
        """PASS if the block runs, FAIL with the exception's text if it raises."""
        try:
            yield
        except Exception as exc:
            self.add(arm, model, flow, "FAIL", f"{type(exc).__name__}: {exc}")
        else:
            self.add(arm, model, flow, "PASS", detail)

    def markdown(self) -> str:
        counts: dict[str, dict[str, int]] = {}
        for s in self.steps:
            c = counts.setdefault(s.arm, {"PASS": 0, "FAIL": 0, "SKIP": 0, "INFO": 0})
            c[s.status] += 1
        rows = ["| arm | PASS | FAIL | SKIP | INFO |", "|---|---|---|---|---|"]
        rows += [f"| {a} | {c['PASS']} | {c['FAIL']} | {c['SKIP']} | {c['INFO']} |"
                 for a, c in counts.items()]
        rows += ["", "| arm | model | flow | result | detail |", "|---|---|---|---|---|"]
        for s in self.steps:
            detail = s.detail.replace("|", "\\|").replace("\n", " ")
            rows.append(f"| {s.arm} | {s.model} | {s.flow} | {s.status} | {detail} |")
        return "\n".join(rows)


def _err(exc: BaseException) -> str:
    return " ".join(f"{type(exc).__name__}: {exc}".split())


# --------------------------------------------------------------------------------------------
# the simulator process


class Sim:
    """`armctl sim --json CONFIG` in a child process: its pty and its console."""

    GET_LINE = re.compile(r"\(id (\d+)\): .*\[(-?\d+) ticks\]|^servo (\d+): (-?\d+) ticks")

    wire_timing = False  # pass --wire-timing to every simulator (replies paced as on the wire)

    def __init__(self, armctl: list[str], config: str) -> None:
        self.config = config
        timing = ["--wire-timing"] if self.wire_timing else []
        self.proc = subprocess.Popen(
            [*armctl, "sim", "--json", *timing, config], stdin=subprocess.PIPE,
            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, bufsize=1,
        )
        assert self.proc.stdout is not None
        text = ""
        deadline = time.monotonic() + 120.0
        info: dict[str, Any] | None = None
        while info is None:
            line = self.proc.stdout.readline()
            if not line or time.monotonic() > deadline:
                raise RuntimeError(f"armctl sim {config} did not start: {text.strip()[-800:]}")
            text += line
            if line.rstrip() == "}":
                with contextlib.suppress(json.JSONDecodeError):
                    info = json.loads(text[text.index("{"):])
        if not info.get("ok", False):
            message = info.get("error", {}).get("message", text)
            raise RuntimeError(f"armctl sim {config}: {message}")
        self.port: str = info["port"]
        self.protocol: str = info["protocol"]
        self.baudrate: int = int(info["baudrate"])
        self.ids: list[int] = [int(i) for i in info["servos"]]
        self._lines: queue.Queue[str] = queue.Queue()
        self._lock = threading.Lock()
        threading.Thread(target=self._pump, daemon=True).start()

    def _pump(self) -> None:
        assert self.proc.stdout is not None
        for line in self.proc.stdout:
            self._lines.put(line.rstrip("\n"))

    def _drain(self) -> None:
        while True:
            try:
                self._lines.get_nowait()
            except queue.Empty:
                return

    def command(self, line: str, timeout: float = 5.0) -> str:
        """Send one console line; return its 'ok' / 'error: ...' answer."""
        assert self.proc.stdin is not None
        with self._lock:
            self._drain()
            self.proc.stdin.write(line + "\n")
            self.proc.stdin.flush()
            deadline = time.monotonic() + timeout
            while time.monotonic() < deadline:
                try:
                    out = self._lines.get(timeout=0.1)
                except queue.Empty:
                    continue
                if out == "ok" or out.startswith("error"):
                    return out
            return "error: no answer from the simulator console"

    def positions(self, timeout: float = 5.0) -> dict[int, int]:
        """Ticks per servo id as the console's `get` reports them."""
        assert self.proc.stdin is not None
        with self._lock:
            self._drain()
            self.proc.stdin.write("get\n")
            self.proc.stdin.flush()
            found: dict[int, int] = {}
            deadline = time.monotonic() + timeout
            while len(found) < len(self.ids) and time.monotonic() < deadline:
                try:
                    out = self._lines.get(timeout=0.1)
                except queue.Empty:
                    continue
                m = self.GET_LINE.search(out)
                if m:
                    sid, ticks = (m.group(1, 2) if m.group(1) else m.group(3, 4))
                    found[int(sid)] = int(ticks)
            return found

    def hand_guide(self, servo_id: int, ticks: int) -> str:
        return self.command(f"ticks {servo_id} {int(ticks)}")

    def stop(self) -> None:
        if self.proc.poll() is None:
            with contextlib.suppress(OSError, ValueError):
                assert self.proc.stdin is not None
                self.proc.stdin.write("quit\n")
                self.proc.stdin.flush()
            try:
                self.proc.wait(timeout=5)
            except subprocess.TimeoutExpired:
                self.proc.terminate()
                self.proc.wait(timeout=5)


# --------------------------------------------------------------------------------------------
# helpers over LeRobot's buses


def _bus_class(protocol: str) -> type:
    if protocol == "feetech":
        return FeetechMotorsBus
    if protocol == "dynamixel":
        return DynamixelMotorsBus
    raise ValueError(f"LeRobot has no bus for protocol {protocol!r} (Dynamixel 2.0 or Feetech)")


def _model_names(bus_cls: type) -> dict[int, str]:
    names: dict[int, str] = {}
    for name, number in bus_cls.model_number_table.items():
        names.setdefault(number, name)
    return names


def _raw(bus: Any, name: str, motor: str) -> int:
    return int(bus.read(name, motor, normalize=False))


def _wait(pred: Callable[[], bool], timeout: float, period: float = 0.02) -> bool:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if pred():
            return True
        time.sleep(period)
    return pred()


def _moves(bus: Any, motor: str, p0: int, timeout: float, beyond: int = 200
           ) -> tuple[bool, list[int]]:
    """Poll Present_Position until it is more than `beyond` ticks from `p0` [tick]."""
    seen: list[int] = []
    deadline = time.monotonic() + timeout
    while True:
        p = _raw(bus, "Present_Position", motor)
        seen.append(p)
        if abs(p - p0) > abs(beyond):
            return True, seen
        if time.monotonic() > deadline:
            return False, seen
        time.sleep(0.02)


def _settle(bus: Any, motor: str, timeout: float = 2.0) -> None:
    """Wait until the servo reports Moving = 0 (or `timeout` [s])."""
    _wait(lambda: _raw(bus, "Moving", motor) == 0, timeout)
    time.sleep(0.05)


def _by_model(motors: dict[str, Motor]) -> dict[str, list[str]]:
    out: dict[str, list[str]] = {}
    for name, m in motors.items():
        out.setdefault(m.model, []).append(name)
    return out


# --------------------------------------------------------------------------------------------
# bus-level flows


def bus_flows(rec: Recorder, sim: Sim, arm: str) -> None:
    """Drive one LeRobot motor bus through its flows on one simulator."""
    try:
        bus_cls = _bus_class(sim.protocol)
    except ValueError as exc:
        rec.add(arm, "-", "bus", "SKIP", str(exc))
        return
    vendor = "feetech" if bus_cls is FeetechMotorsBus else "dynamixel"

    # scan_port: every baud rate LeRobot scans, broadcast ping at each
    try:
        found = bus_cls.scan_port(sim.port)
        ids = found.get(sim.baudrate, [])
        rec.check(arm, "-", "scan_port", sorted(ids) == sorted(sim.ids),
                  f"found {found}; simulator serves {sim.ids} at {sim.baudrate}")
    except Exception as exc:
        rec.add(arm, "-", "scan_port", "FAIL", _err(exc))

    # broadcast_ping on a bus without motors: ids and model numbers
    names = _model_names(bus_cls)
    motors: dict[str, Motor] = {}
    probe = bus_cls(sim.port, {})
    try:
        probe.connect(handshake=False)
        pinged = probe.broadcast_ping(num_retry=2, raise_on_error=True) or {}
        unknown = {i: n for i, n in pinged.items() if n not in names}
        rec.check(arm, "-", "broadcast_ping",
                  sorted(pinged) == sorted(sim.ids) and not unknown,
                  f"id -> model number {pinged}"
                  + (f"; numbers unknown to LeRobot: {unknown}" if unknown else ""))
        for i, n in sorted(pinged.items()):
            if n in names:
                motors[f"id{i}"] = Motor(i, names[n], MotorNormMode.RANGE_M100_100)
    except Exception as exc:
        rec.add(arm, "-", "broadcast_ping", "FAIL", _err(exc))
    finally:
        with contextlib.suppress(Exception):
            probe.port_handler.closePort()
    if not motors:
        rec.add(arm, "-", "bus flows", "SKIP", "no servo LeRobot knows answered")
        return
    models = _by_model(motors)
    label = ",".join(sorted(models))

    bus = bus_cls(sim.port, motors)
    try:
        bus.connect(handshake=True)
        rec.add(arm, label, "connect (handshake: ping + model check"
                + (" + firmware check)" if vendor == "feetech" else ")"), "PASS")
    except Exception as exc:
        cause = f" (caused by {_err(exc.__cause__)})" if exc.__cause__ else ""
        rec.add(arm, label, "connect (handshake)", "FAIL", _err(exc) + cause)
        with contextlib.suppress(Exception):
            bus.connect(handshake=False)
    if not bus.is_connected:
        return
    try:
        _bus_body(rec, sim, arm, bus, vendor, motors, models)
    except Exception as exc:  # a step outside its own check: the rest of the flows is lost
        rec.add(arm, label, "bus flows (stopped)", "FAIL", _err(exc))
    finally:
        try:
            bus.disconnect(disable_torque=True)
            rec.add(arm, label, "disconnect (torque off)", "PASS")
        except Exception as exc:
            rec.add(arm, label, "disconnect (torque off)", "FAIL", _err(exc))


def _bus_body(rec: Recorder, sim: Sim, arm: str, bus: Any, vendor: str,
              motors: dict[str, Motor], models: dict[str, list[str]]) -> None:
    read_only = FT_READ_ONLY if vendor == "feetech" else DXL_READ_ONLY
    _latency_flow(rec, arm, bus, motors)

    for model, names in models.items():
        got = {name: bus.ping(name, num_retry=1) for name in names}
        rec.check(arm, model, "ping -> model number",
                  all(n == bus.model_number_table[model] for n in got.values()),
                  f"{got}, LeRobot expects {bus.model_number_table[model]}")

    # read / sync_read every register of LeRobot's table
    for model, names in models.items():
        table = get_ctrl_table(bus.model_ctrl_table, model)
        bad_read: list[str] = []
        bad_sync: list[str] = []
        values: dict[str, int] = {}
        for reg, (addr, size) in table.items():
            try:
                values[reg] = _raw(bus, reg, names[0])
            except Exception as exc:
                bad_read.append(f"{reg} (addr {addr}, {size} B): {_err(exc)}")
            try:
                got = bus.sync_read(reg, names, normalize=False)
                if sorted(got) != sorted(names):
                    bad_sync.append(f"{reg} (addr {addr}): replies for {sorted(got)}")
                elif reg in values and reg not in LIVE and got[names[0]] != values[reg]:
                    bad_sync.append(f"{reg} (addr {addr}): sync_read {got[names[0]]} "
                                    f"!= read {values[reg]}")
            except Exception as exc:
                bad_sync.append(f"{reg} (addr {addr}, {size} B): {_err(exc)}")
        rec.check(arm, model, f"read every register ({len(table)})", not bad_read,
                  "; ".join(bad_read))
        rec.check(arm, model, f"sync_read every register ({len(table)})", not bad_sync,
                  "; ".join(bad_sync))
        zero = [r for r in ("Present_Input_Voltage", "Present_Voltage", "Present_Temperature")
                if r in values and values[r] == 0]
        rec.check(arm, model, "idle readings plausible (voltage, temperature)", not zero,
                  f"read 0: {zero}" if zero else
                  ", ".join(f"{r}={values[r]}" for r in ("Present_Input_Voltage",
                            "Present_Voltage", "Present_Temperature") if r in values))

    # torque off (and Lock 0 on Feetech) for the EEPROM writes
    with rec.guard(arm, ",".join(models), "disable_torque"):
        bus.disable_torque(num_retry=1)
    off = {n: _raw(bus, "Torque_Enable", n) for n in motors}
    rec.check(arm, ",".join(models), "Torque_Enable reads 0 after disable_torque",
              all(v == 0 for v in off.values()), str(off))

    # write every writable register: own value, then a changed value read back, then restore
    for model, names in models.items():
        table = get_ctrl_table(bus.model_ctrl_table, model)
        motor = names[0]
        same_bad: list[str] = []
        change_bad: list[str] = []
        absent: list[str] = []
        for reg, (addr, size) in table.items():
            if reg in read_only:
                continue
            if reg in NOT_IN_MAKER_TABLE.get(model, set()):
                try:
                    bus.write(reg, motor, _raw(bus, reg, motor), normalize=False)
                    absent.append(f"{reg} (addr {addr}): write acknowledged")
                except Exception as exc:
                    absent.append(f"{reg} (addr {addr}): {_err(exc)}")
                continue
            try:
                v0 = _raw(bus, reg, motor)
            except Exception as exc:
                same_bad.append(f"{reg} (addr {addr}): read failed {_err(exc)}")
                continue
            try:
                bus.write(reg, motor, v0, normalize=False)
            except Exception as exc:
                same_bad.append(f"{reg} (addr {addr}, {size} B) value {v0}: {_err(exc)}")
                continue
            if reg in NO_CHANGE:
                continue
            errors = []
            for v1 in ([v0 - 1, v0 + 1] if v0 > 0 else [v0 + 1]):
                try:
                    bus.write(reg, motor, v1, normalize=False)
                except Exception as exc:
                    errors.append(f"write {v1}: {_err(exc)}")
                    continue
                back = _raw(bus, reg, motor)
                if back != v1:
                    errors.append(f"wrote {v1}, reads {back}")
                    continue
                errors = []
                break
            if errors:
                change_bad.append(f"{reg} (addr {addr}, {size} B, was {v0}): " + "; ".join(errors))
            with contextlib.suppress(Exception):
                bus.write(reg, motor, v0, normalize=False)
        writable = [r for r in table if r not in read_only
                    and r not in NOT_IN_MAKER_TABLE.get(model, set())]
        rec.check(arm, model, f"write every RW register with its own value ({len(writable)})",
                  not same_bad, "; ".join(same_bad))
        if absent:
            rec.add(arm, model, "write to items not in the maker's table for this model", "INFO",
                    "; ".join(absent))
        changed = [r for r in writable if r not in NO_CHANGE]
        rec.check(arm, model, f"write every RW register with a new value, read back "
                  f"({len(changed)})", not change_bad,
                  "; ".join(change_bad)
                  or f"kept their value: {sorted(set(writable) - set(changed))}")

        # writes to read-only registers
        ro_bad: list[str] = []
        for reg, (addr, _size) in table.items():
            if reg not in read_only or reg in LIVE:
                continue
            v0 = _raw(bus, reg, motor)
            v1 = v0 + 1 if v0 < 255 else v0 - 1
            refused = False
            try:
                bus.write(reg, motor, v1, normalize=False)
            except RuntimeError as exc:
                refused = "not available" in str(exc) or "Access" in str(exc)
                if not refused:
                    ro_bad.append(f"{reg} (addr {addr}): unexpected {_err(exc)}")
                    continue
            except Exception as exc:
                ro_bad.append(f"{reg} (addr {addr}): {_err(exc)}")
                continue
            after = _raw(bus, reg, motor)
            if after != v0:
                ro_bad.append(f"{reg} (addr {addr}): read-only value changed {v0} -> {after}")
            elif vendor == "dynamixel" and not refused:
                ro_bad.append(f"{reg} (addr {addr}): write acknowledged without the access "
                              "error (0x07) the servo answers")
        rec.check(arm, model, "write to read-only registers refused/ignored", not ro_bad,
                  "; ".join(ro_bad))

    with rec.guard(arm, ",".join(models), "configure_motors"):
        bus.configure_motors()

    _calibration_flows(rec, arm, bus, motors, models)
    _torque_flows(rec, arm, bus, vendor, motors, models)
    _motion_flow(rec, arm, bus, vendor, motors, models)
    if vendor == "dynamixel":
        _dxl_mode_flows(rec, arm, bus, motors, models)
        _drive_mode_flow(rec, sim, arm, bus, motors, models)
    else:
        _ft_mode_flows(rec, arm, bus, motors, models)
    _setup_motor_flow(rec, sim, arm, bus, motors)


def _setup_motor_flow(rec: Recorder, sim: Sim, arm: str, bus: Any,
                      motors: dict[str, Motor]) -> None:
    """LeRobot's `setup_motor` (lerobot-setup-motors): new id and the bus baud rate."""
    name = list(motors)[-1]
    m = motors[name]
    bus_cls = type(bus)
    # LeRobot's Feetech table maps 57600 to code 5, which the maker's STS3215 table gives to
    # 76800 (57600 is code 6): use a rate both agree on
    slow = 115_200 if isinstance(bus, FeetechMotorsBus) else 57_600
    new_id = max(mm.id for mm in motors.values()) + 10
    flow = f"setup_motor: id {m.id} at {slow} baud -> id {new_id} at {bus.default_baudrate}"
    try:
        bus.disable_torque(name)
        bus.write("Baud_Rate", name, bus.model_baudrate_table[m.model][slow])
        gone = bus.ping(m.id)
        bus.port_handler.closePort()
        setup = bus_cls(sim.port, {"moved": Motor(new_id, m.model, MotorNormMode.RANGE_M100_100)})
        try:
            setup.setup_motor("moved", initial_baudrate=slow, initial_id=m.id)
            found_new = setup.ping("moved")
            found_old = setup.ping(m.id)
            # and back, through the same flow
            back = bus_cls(sim.port, {name: Motor(m.id, m.model, MotorNormMode.RANGE_M100_100)})
            setup.port_handler.closePort()
            back.setup_motor(name, initial_baudrate=bus.default_baudrate, initial_id=new_id)
            restored = back.ping(name)
            back.port_handler.closePort()
        finally:
            with contextlib.suppress(Exception):
                setup.port_handler.closePort()
            bus.port_handler.openPort()
            bus.set_baudrate(bus.default_baudrate)
        expected = bus.model_number_table[m.model]
        rec.check(arm, m.model, flow,
                  gone is None and found_new == expected and found_old is None
                  and restored == expected,
                  f"ping id {m.id} at {bus.default_baudrate} after the baud change: {gone}; "
                  f"after setup_motor id {new_id}: {found_new}, id {m.id}: {found_old}; "
                  f"after moving it back: {restored}")
    except Exception as exc:
        rec.add(arm, m.model, flow, "FAIL", _err(exc))


def _calibration_flows(rec: Recorder, arm: str, bus: Any, motors: dict[str, Motor],
                       models: dict[str, list[str]]) -> None:
    label = ",".join(models)
    try:
        before = bus.read_calibration()
        rec.add(arm, label, "read_calibration", "PASS",
                f"{len(before)} motors, e.g. {next(iter(before.values()))}")
    except Exception as exc:
        rec.add(arm, label, "read_calibration", "FAIL", _err(exc))
        return
    try:
        homings = bus.set_half_turn_homings()
        present = bus.sync_read("Present_Position", normalize=False)
        off = {n: p for n, p in present.items() if abs(p - 2047) > 2}
        rec.check(arm, label, "set_half_turn_homings -> Present_Position reads 2047", not off,
                  f"homing offsets {homings}" + (f"; Present_Position {off}" if off else ""))
    except Exception as exc:
        rec.add(arm, label, "set_half_turn_homings", "FAIL", _err(exc))
        homings = {n: 0 for n in motors}
    calib = {
        n: MotorCalibration(id=m.id, drive_mode=0, homing_offset=int(homings[n]),
                            range_min=2047 - 700, range_max=2047 + 700)
        for n, m in motors.items()
    }
    try:
        bus.write_calibration(calib)
        back = bus.read_calibration()
        diff = {n: (calib[n], back[n]) for n in motors if back[n] != calib[n]}
        rec.check(arm, label, "write_calibration / read_calibration round trip", not diff,
                  str(diff) if diff else "")
        rec.check(arm, label, "is_calibrated after write_calibration", bool(bus.is_calibrated))
        norm = bus.sync_read("Present_Position")
        far = {n: v for n, v in norm.items() if abs(v) > 2.0}
        rec.check(arm, label, "normalised Present_Position ~0 at half turn", not far,
                  str(norm))
    except Exception as exc:
        rec.add(arm, label, "write_calibration / read_calibration", "FAIL", _err(exc))
    with rec.guard(arm, label, "reset_calibration"):
        bus.reset_calibration()


def _torque_flows(rec: Recorder, arm: str, bus: Any, vendor: str, motors: dict[str, Motor],
                  models: dict[str, list[str]]) -> None:
    label = ",".join(models)
    try:
        bus.enable_torque(num_retry=1)
        on = {n: _raw(bus, "Torque_Enable", n) for n in motors}
        detail = f"Torque_Enable {on}"
        ok = all(v == 1 for v in on.values())
        if vendor == "feetech":
            lock = {n: _raw(bus, "Lock", n) for n in motors}
            ok = ok and all(v == 1 for v in lock.values())
            detail += f"; Lock {lock}"
        rec.check(arm, label, "enable_torque", ok, detail)
    except Exception as exc:
        rec.add(arm, label, "enable_torque", "FAIL", _err(exc))
        return
    # an EEPROM write while torque is on: refused (Dynamixel access error) / ignored (Feetech)
    for model, names in models.items():
        motor = names[0]
        reg = "Return_Delay_Time"
        v0 = _raw(bus, reg, motor)
        v1 = v0 + 1 if v0 < 200 else v0 - 1
        try:
            bus.write(reg, motor, v1, normalize=False)
            after = _raw(bus, reg, motor)
            if vendor == "dynamixel":
                rec.check(arm, model, "EEPROM write with torque on refused", False,
                          f"{reg} write {v1} acknowledged (reads {after}); the servo answers "
                          "access error 0x07")
            else:
                rec.check(arm, model, "EEPROM write with torque on + Lock 1 ignored",
                          after == v0, f"{reg} was {v0}, wrote {v1}, reads {after}")
        except RuntimeError as exc:
            rec.check(arm, model, "EEPROM write with torque on refused",
                      vendor == "dynamixel", _err(exc))
        except Exception as exc:
            rec.add(arm, model, "EEPROM write with torque on", "FAIL", _err(exc))
        with contextlib.suppress(Exception):
            bus.disable_torque(motor)
            bus.write(reg, motor, v0, normalize=False)
            bus.enable_torque(motor)
    try:
        bus.disable_torque(num_retry=1)
        off = {n: _raw(bus, "Torque_Enable", n) for n in motors}
        rec.check(arm, label, "disable_torque", all(v == 0 for v in off.values()), str(off))
    except Exception as exc:
        rec.add(arm, label, "disable_torque", "FAIL", _err(exc))


def _sample_motion(bus: Any, motors: list[str], regs: list[str], until: Callable[[], bool],
                   timeout: float) -> dict[str, set[int]]:
    seen: dict[str, set[int]] = {r: set() for r in regs}
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        for r in regs:
            with contextlib.suppress(Exception):
                seen[r].update(int(v) for v in bus.sync_read(r, motors, normalize=False).values())
        if until():
            break
    return seen


def _motion_flow(rec: Recorder, arm: str, bus: Any, vendor: str, motors: dict[str, Motor],
                 models: dict[str, list[str]]) -> None:
    label = ",".join(models)
    names = list(motors)
    try:
        start = bus.sync_read("Present_Position", normalize=False)
        bus.enable_torque()
        if vendor == "dynamixel":  # a trapezoidal profile, so that Moving_Status shows it
            bus.sync_write("Profile_Velocity", 100, normalize=False)
            bus.sync_write("Profile_Acceleration", 20, normalize=False)
        goal = {n: int(p) + (400 if p < 2048 else -400) for n, p in start.items()}
        bus.sync_write("Goal_Position", goal, normalize=False)
        pos: dict[str, int] = {}

        def arrived() -> bool:
            pos.update(bus.sync_read("Present_Position", normalize=False))
            return all(abs(pos[n] - goal[n]) <= 15 for n in names)

        regs = (["Moving", "Present_Velocity", "Present_Load", "Present_Current"]
                if vendor == "feetech" else
                ["Moving", "Moving_Status", "Present_Velocity", "Present_Current",
                 "Present_PWM", "Realtime_Tick"])
        seen = _sample_motion(bus, names, regs, arrived, 6.0)
        ok = arrived()
        rec.check(arm, label, "sync_write Goal_Position -> Present_Position reaches it", ok,
                  f"start {start} goal {goal} present {pos}")
        for r in regs:
            values = seen[r]
            if r == "Moving_Status":
                rec.check(arm, label, "Moving_Status profile-ongoing bit (0x02) during a "
                          "profiled move", any(v & 2 for v in values),
                          f"values seen {sorted(values)[:8]} (Profile_Velocity 100, "
                          "Profile_Acceleration 20)")
                continue
            moving_ok = len(values - {0}) > 0
            rec.check(arm, label, f"{r} non-zero during the move", moving_ok,
                      f"values seen {sorted(values)[:8]}")
        time.sleep(0.3)
        m = bus.sync_read("Moving", names, normalize=False)
        rec.check(arm, label, "Moving back to 0 after arrival",
                  all(v == 0 for v in m.values()), str(m))
        if vendor == "dynamixel":
            st = bus.sync_read("Moving_Status", names, normalize=False)
            rec.check(arm, label, "Moving_Status in-position bit (0x01) set after arrival",
                      all(v & 1 for v in st.values()), str(st))
    except Exception as exc:
        rec.add(arm, label, "sync_write Goal_Position motion", "FAIL", _err(exc))
    finally:
        with contextlib.suppress(Exception):
            bus.disable_torque()
            if vendor == "dynamixel":
                bus.sync_write("Profile_Velocity", 0, normalize=False)
                bus.sync_write("Profile_Acceleration", 0, normalize=False)


def _latency_flow(rec: Recorder, arm: str, bus: Any, motors: dict[str, Motor]) -> None:
    """Reply time to LeRobot's reads; the SDKs give up after ~34 ms (2 x 16 ms latency timer)."""
    name = next(iter(motors))
    label = ",".join(sorted({m.model for m in motors.values()}))
    for what, call, count in (
        ("read Present_Position", lambda: bus.read("Present_Position", name, normalize=False),
         200),
        (f"sync_read Present_Position x{len(motors)}",
         lambda: bus.sync_read("Present_Position", normalize=False), 1000),
    ):
        times: list[float] = []
        lost = 0
        for _ in range(count):
            t = time.perf_counter()
            try:
                call()
            except ConnectionError:
                lost += 1
            times.append((time.perf_counter() - t) * 1e3)
        times.sort()
        slow = sum(1 for t in times if t > 30.0)
        rec.check(arm, label, f"{count} x {what}: no reply lost", lost == 0,
                  f"{lost} lost; {slow} over 30 ms; reply time median "
                  f"{times[count // 2]:.1f} ms, 99th percentile {times[int(count * 0.99)]:.1f} ms, "
                  f"max {times[-1]:.1f} ms")


def _dxl_mode_flows(rec: Recorder, arm: str, bus: Any, motors: dict[str, Motor],
                    models: dict[str, list[str]]) -> None:
    for model, names in models.items():
        motor = names[0]
        # Goal PWM and Goal Current also cap the output in the position modes: restore them
        goals = {r: _raw(bus, r, motor) for r in ("Goal_PWM", "Goal_Current", "Goal_Velocity")
                 if r not in NOT_IN_MAKER_TABLE.get(model, set())}
        for mode_value in MODEL_OPERATING_MODES.get(model, []):
            mode = DxlMode(mode_value)
            flow = f"Operating_Mode {mode.name} ({mode_value})"
            try:
                bus.disable_torque(motor)
                bus.write("Operating_Mode", motor, mode_value)
                back = _raw(bus, "Operating_Mode", motor)
                if back != mode_value:
                    rec.check(arm, model, flow, False, f"wrote {mode_value}, reads {back}")
                    continue
                p0 = _raw(bus, "Present_Position", motor)
                bus.enable_torque(motor)
                if mode is DxlMode.CURRENT:
                    limit = _raw(bus, "Current_Limit", motor)
                    bus.write("Goal_Current", motor, max(1, limit // 4), normalize=False)
                elif mode is DxlMode.VELOCITY:
                    bus.write("Goal_Velocity", motor, 60, normalize=False)
                elif mode is DxlMode.PWM:
                    bus.write("Goal_PWM", motor, 300, normalize=False)
                elif mode is DxlMode.EXTENDED_POSITION:
                    bus.write("Goal_Position", motor, p0 + 5000, normalize=False)
                else:  # POSITION, CURRENT_POSITION
                    if mode is DxlMode.CURRENT_POSITION:
                        bus.write("Goal_Current", motor, _raw(bus, "Current_Limit", motor),
                                  normalize=False)
                    bus.write("Goal_Position", motor, p0 + (300 if p0 < 2048 else -300),
                              normalize=False)
                ok, seen = _moves(bus, motor, p0, 3.0)
                extra = ""
                if mode is DxlMode.EXTENDED_POSITION:
                    _moves(bus, motor, p0, 6.0, beyond=4095 + 100 - p0)
                    p = _raw(bus, "Present_Position", motor)
                    ok = ok and p > 4095
                    extra = f"; goal {p0 + 5000} present {p}"
                cur = _raw(bus, "Present_Current", motor)
                vel = _raw(bus, "Present_Velocity", motor)
                rec.check(arm, model, flow + ": shaft moves", ok,
                          f"Present_Position from {p0} through {seen[-3:]}{extra}; "
                          f"Present_Velocity {vel}, Present_Current {cur}")
            except Exception as exc:
                rec.add(arm, model, flow, "FAIL", _err(exc))
            finally:
                with contextlib.suppress(Exception):
                    bus.disable_torque(motor)
                    bus.write("Operating_Mode", motor, DxlMode.POSITION.value)
                    for reg, value in goals.items():
                        bus.write(reg, motor, value, normalize=False)


def _drive_mode_flow(rec: Recorder, sim: Sim, arm: str, bus: Any, motors: dict[str, Motor],
                     models: dict[str, list[str]]) -> None:
    for model, names in models.items():
        motor = names[0]
        sid = motors[motor].id
        flow = "Drive_Mode reverse (bit 0)"
        try:
            bus.disable_torque(motor)
            dm0 = _raw(bus, "Drive_Mode", motor)
            answer = sim.hand_guide(sid, 1000)
            p_fwd = _raw(bus, "Present_Position", motor)
            bus.write("Drive_Mode", motor, dm0 | 1)
            p_rev = _raw(bus, "Present_Position", motor)
            bus.enable_torque(motor)
            bus.write("Goal_Position", motor, p_rev + 300, normalize=False)
            _moves(bus, motor, p_rev, 3.0, beyond=285)
            _settle(bus, motor)
            p_goal = _raw(bus, "Present_Position", motor)
            bus.disable_torque(motor)
            shaft = sim.positions().get(sid)
            rec.check(arm, model, flow + ": reading mirrored", p_rev != p_fwd,
                      f"hand-guided to 1000 ({answer}); Present_Position {p_fwd} forward, "
                      f"{p_rev} with Drive_Mode {dm0 | 1}")
            rec.check(arm, model, flow + ": goal reached in the reversed frame",
                      abs(p_goal - (p_rev + 300)) < 15,
                      f"goal {p_rev + 300}, present {p_goal}, console reports {shaft}")
        except Exception as exc:
            rec.add(arm, model, flow, "FAIL", _err(exc))
        finally:
            with contextlib.suppress(Exception):
                bus.disable_torque(motor)
                bus.write("Drive_Mode", motor, 0)


def _ft_mode_flows(rec: Recorder, arm: str, bus: Any, motors: dict[str, Motor],
                   models: dict[str, list[str]]) -> None:
    for model, names in models.items():
        motor = names[0]
        for mode in (FtMode.POSITION, FtMode.VELOCITY):
            flow = f"Operating_Mode {mode.name} ({mode.value})"
            try:
                bus.disable_torque(motor)
                bus.write("Operating_Mode", motor, mode.value)
                back = _raw(bus, "Operating_Mode", motor)
                if back != mode.value:
                    rec.check(arm, model, flow, False, f"wrote {mode.value}, reads {back}")
                    continue
                p0 = _raw(bus, "Present_Position", motor)
                bus.enable_torque(motor)
                if mode is FtMode.VELOCITY:
                    bus.write("Goal_Velocity", motor, 600, normalize=False)
                else:
                    bus.write("Goal_Position", motor, p0 + (300 if p0 < 2048 else -300),
                              normalize=False)
                ok, seen = _moves(bus, motor, p0, 3.0)
                vel = _raw(bus, "Present_Velocity", motor)
                rec.check(arm, model, flow + ": shaft moves", ok,
                          f"Present_Position from {p0} through {seen[-3:]}; "
                          f"Present_Velocity {vel}")
            except Exception as exc:
                rec.add(arm, model, flow, "FAIL", _err(exc))
            finally:
                with contextlib.suppress(Exception):
                    bus.write("Goal_Velocity", motor, 0, normalize=False)
                    bus.disable_torque(motor)
                    bus.write("Operating_Mode", motor, FtMode.POSITION.value)


# --------------------------------------------------------------------------------------------
# robot-level flows


@contextlib.contextmanager
def _console(answers: Callable[[str], str], on_enter_poll: Callable[[], bool]) -> Iterator[str]:
    """Answer `input()` prompts and LeRobot's `enter_pressed()`; capture what is printed."""
    out = io.StringIO()
    saved_input = builtins.input
    saved_enter = lr_motors_bus.enter_pressed
    builtins.input = lambda prompt="": answers(str(prompt))  # type: ignore[assignment]
    lr_motors_bus.enter_pressed = on_enter_poll  # type: ignore[assignment]
    try:
        with contextlib.redirect_stdout(out):
            yield "console"
    finally:
        builtins.input = saved_input
        lr_motors_bus.enter_pressed = saved_enter


class Sweep:
    """Hand-guides servos through the simulator's console, one step per poll."""

    def __init__(self, sim: Sim, ids: list[int], amplitude: int, steps: int) -> None:
        self.sim, self.ids, self.amplitude, self.steps = sim, ids, amplitude, steps
        self.n = 0
        self.base: dict[int, int] = {}
        self.errors: list[str] = []

    def poll(self) -> bool:
        if not self.base:
            self.base = self.sim.positions()
        self.n += 1
        if self.n > self.steps:
            for sid in self.ids:  # back to the middle
                self.sim.hand_guide(sid, self.base[sid])
            return True
        phase = 2 * math.pi * self.n / self.steps
        for k, sid in enumerate(self.ids):
            target = self.base[sid] + round(self.amplitude * math.sin(phase + k))
            answer = self.sim.hand_guide(sid, target)
            if answer != "ok":
                self.errors.append(f"ticks {sid} {target}: {answer}")
        return False


def _make_pair(kind: str, follower_port: str, leader_port: str, calib_dir: Path
               ) -> tuple[Any, Any]:
    if kind == "so101":
        from lerobot.robots.so_follower import SO101Follower, SO101FollowerConfig
        from lerobot.teleoperators.so_leader import SO101Leader, SO101LeaderConfig

        follower = SO101Follower(SO101FollowerConfig(
            port=follower_port, id="armctl_sim", calibration_dir=calib_dir / "follower"))
        leader = SO101Leader(SO101LeaderConfig(
            port=leader_port, id="armctl_sim", calibration_dir=calib_dir / "leader"))
        return follower, leader
    if kind == "koch":
        from lerobot.robots.koch_follower import KochFollower, KochFollowerConfig
        from lerobot.teleoperators.koch_leader import KochLeader, KochLeaderConfig

        follower = KochFollower(KochFollowerConfig(
            port=follower_port, id="armctl_sim", calibration_dir=calib_dir / "follower"))
        leader = KochLeader(KochLeaderConfig(
            port=leader_port, id="armctl_sim", calibration_dir=calib_dir / "leader"))
        return follower, leader
    raise ValueError(kind)


FULL_TURN = {"so101": {"wrist_roll"}, "koch": {"shoulder_pan", "wrist_roll"}}


def _calibrate(rec: Recorder, arm: str, device: Any, sim: Sim, kind: str) -> bool:
    motors = device.bus.motors
    sweep_ids = [m.id for n, m in motors.items() if n not in FULL_TURN[kind]]
    sweep = Sweep(sim, sweep_ids, amplitude=600, steps=40)
    prompts: list[str] = []

    def answer(prompt: str) -> str:
        prompts.append(prompt)
        return "c" if "type 'c'" in prompt else ""

    try:
        with _console(answer, sweep.poll):
            device.connect(calibrate=True)
    except Exception as exc:
        rec.add(arm, "-", f"{device} connect() with calibrate()", "FAIL", _err(exc))
        with contextlib.suppress(Exception):
            device.disconnect()
        return False
    cal = device.calibration
    bad = {}
    for name, c in cal.items():
        if name in FULL_TURN[kind]:
            continue
        if not (abs(c.range_min - (2047 - 600)) <= 30 and abs(c.range_max - (2047 + 600)) <= 30):
            bad[name] = (c.range_min, c.range_max)
    rec.check(arm, "-", f"{device} connect() runs calibrate() (prompts answered, joints "
              "hand-guided)", not bad and not sweep.errors and device.calibration_fpath.is_file(),
              f"file {device.calibration_fpath.name} written: "
              f"{device.calibration_fpath.is_file()}; "
              + (f"ranges off the swept 1447..2647: {bad}; console errors {sweep.errors[:3]}"
                 if bad or sweep.errors else
                 f"ranges {[(n, c.range_min, c.range_max) for n, c in cal.items()][:3]}..."))
    with contextlib.suppress(Exception):
        device.disconnect()
    return True


def _cli_calibrate(rec: Recorder, arm: str, kind: str, role: str, sim: Sim,
                   calib_dir: Path) -> None:
    """`lerobot-calibrate` (its `main()`, in this process) on one simulator."""
    from lerobot.scripts import lerobot_calibrate

    device_type = f"{kind}_{'follower' if role == 'robot' else 'leader'}"
    argv = [f"--{role}.type={device_type}", f"--{role}.port={sim.port}",
            f"--{role}.id=cli", f"--{role}.calibration_dir={calib_dir}"]
    names = ["shoulder_pan", "shoulder_lift", "elbow_flex", "wrist_flex", "wrist_roll", "gripper"]
    sweep_ids = [i + 1 for i, n in enumerate(names) if n not in FULL_TURN[kind]]
    sweep = Sweep(sim, sweep_ids, amplitude=500, steps=30)
    saved_argv = sys.argv
    sys.argv = ["lerobot-calibrate", *argv]
    flow = "lerobot-calibrate " + " ".join(argv).replace(sim.port, "PTY").replace(
        str(calib_dir), "DIR")
    try:
        with _console(lambda prompt: "c" if "type 'c'" in prompt else "", sweep.poll):
            lerobot_calibrate.main()
        files = sorted(p.name for p in calib_dir.glob("*.json"))
        cal = json.loads((calib_dir / "cli.json").read_text())
        bad = {n: (c["range_min"], c["range_max"]) for n, c in cal.items()
               if n not in FULL_TURN[kind] and not (
                   abs(c["range_min"] - 1547) <= 30 and abs(c["range_max"] - 2547) <= 30)}
        rec.check(arm, "-", flow, not bad and not sweep.errors,
                  f"wrote {files}" + (f"; ranges off the swept 1547..2547: {bad}" if bad else "")
                  + (f"; console errors {sweep.errors[:3]}" if sweep.errors else ""))
    except (Exception, SystemExit) as exc:  # draccus exits on bad arguments
        rec.add(arm, "-", flow, "FAIL", _err(exc))
    finally:
        sys.argv = saved_argv
        logging.getLogger().setLevel(logging.WARNING)


def robot_flows(rec: Recorder, armctl: list[str], kind: str, follower_cfg: str, leader_cfg: str,
                steps: int, frames_out: Path | None) -> None:
    """Calibrate, reconnect, observe, act and teleoperate one follower/leader pair."""
    arm = f"{kind} pair"
    sims: list[Sim] = []
    try:
        try:
            fsim = _start(armctl, follower_cfg)
            sims.append(fsim)
            try:
                lsim = _start(armctl, leader_cfg)
            except NotBundled:
                if kind != "so101":
                    raise
                leader_cfg = follower_cfg  # an older armctl without the leader arm
                lsim = _start(armctl, leader_cfg)
            sims.append(lsim)
        except NotBundled as exc:
            rec.add(arm, "-", "start simulators", "SKIP", str(exc))
            return
        except Exception as exc:
            rec.add(arm, "-", "start simulators", "FAIL", _err(exc))
            return
        rec.add(arm, "-", "start simulators", "PASS",
                f"follower {follower_cfg} on {fsim.port}, leader {leader_cfg} on {lsim.port}")
        with tempfile.TemporaryDirectory(prefix="lerobot_calib_") as tmp:
            calib_dir = Path(tmp)
            follower, leader = _make_pair(kind, fsim.port, lsim.port, calib_dir)
            if not _calibrate(rec, arm, follower, fsim, kind):
                return
            if not _calibrate(rec, arm, leader, lsim, kind):
                return
            follower, leader = _make_pair(kind, fsim.port, lsim.port, calib_dir)
            _pair_session(rec, arm, kind, follower, leader, fsim, lsim, steps, frames_out)
            for role, sim in (("robot", fsim), ("teleop", lsim)):
                _cli_calibrate(rec, arm, kind, role, sim, calib_dir / "cli")
    finally:
        for s in sims:
            s.stop()


def _pair_session(rec: Recorder, arm: str, kind: str, follower: Any, leader: Any, fsim: Sim,
                  lsim: Sim, steps: int, frames_out: Path | None) -> None:
    for device in (follower, leader):
        try:
            device.connect(calibrate=False)
            rec.check(arm, "-", f"{device} connect(calibrate=False) with the saved file; "
                      "is_calibrated", bool(device.is_calibrated))
        except Exception as exc:
            rec.add(arm, "-", f"{device} connect(calibrate=False)", "FAIL", _err(exc))
            return
    try:
        try:
            obs = follower.get_observation()
            keys_ok = set(obs) == set(follower.observation_features)
            rec.check(arm, "-", f"{follower} get_observation", keys_ok,
                      ", ".join(f"{k}={v:.1f}" for k, v in obs.items()))
        except Exception as exc:
            rec.add(arm, "-", f"{follower} get_observation", "FAIL", _err(exc))
            return
        retries = getattr(follower.config, "num_read_retries", 0)
        if retries:  # a lost reply, as on a noisy line: LeRobot's retry must see the next one
            answer = fsim.command("fault dropped_reply 3 1")
            try:
                again = follower.get_observation()
                rec.check(arm, "-", f"{follower} get_observation with one reply of servo 3 lost "
                          f"(num_read_retries={retries})", set(again) == set(obs),
                          f"console: {answer}")
            except Exception as exc:
                rec.add(arm, "-", f"{follower} get_observation with one reply lost", "FAIL",
                        f"console: {answer}; {_err(exc)}")
        try:
            action = {k: (v + 10.0 if v < 0 else v - 10.0) for k, v in obs.items()}
            sent = follower.send_action(action)
            after: dict[str, float] = {}

            def close() -> bool:
                after.update(follower.get_observation())
                return all(abs(after[k] - sent[k]) < 1.5 for k in sent)

            ok = _wait(close, 4.0)
            rec.check(arm, "-", f"{follower} send_action -> observation follows", ok,
                      "; ".join(f"{k}: sent {sent[k]:.1f} obs {after.get(k, float('nan')):.1f}"
                                for k in sent))
        except Exception as exc:
            rec.add(arm, "-", f"{follower} send_action", "FAIL", _err(exc))
        try:
            action0 = leader.get_action()
            rec.check(arm, "-", f"{leader} get_action", set(action0) == set(
                leader.action_features), ", ".join(f"{k}={v:.1f}" for k, v in action0.items()))
        except Exception as exc:
            rec.add(arm, "-", f"{leader} get_action", "FAIL", _err(exc))
            return
        _teleop(rec, arm, kind, follower, leader, fsim, lsim, steps, frames_out)
    finally:
        for device in (follower, leader):
            try:
                device.disconnect()
                rec.add(arm, "-", f"{device} disconnect", "PASS")
            except Exception as exc:
                rec.add(arm, "-", f"{device} disconnect", "FAIL", _err(exc))


def _teleop(rec: Recorder, arm: str, kind: str, follower: Any, leader: Any, fsim: Sim,
            lsim: Sim, steps: int, frames_out: Path | None) -> None:
    movable = [m.id for n, m in leader.bus.motors.items()
               if not (kind == "koch" and n == "gripper")]  # Koch leader gripper holds torque
    base = lsim.positions()
    frames: list[dict[str, Any]] = []
    errors: list[str] = []
    period = 1.0 / 30.0
    t0 = time.perf_counter()
    worst = 0.0
    slowest = 0.0  # [s] the longest get_observation()
    stage = ""
    try:
        for i in range(steps):
            tick = time.perf_counter()
            phase = 2 * math.pi * i / 150.0
            for k, sid in enumerate(movable):
                answer = lsim.hand_guide(sid, base[sid] + round(400 * math.sin(phase + k)))
                if answer != "ok" and len(errors) < 3:
                    errors.append(f"ticks {sid}: {answer}")
            stage = f"{leader}.get_action()"
            action = leader.get_action()
            stage = f"{follower}.send_action()"
            sent = follower.send_action(action)
            stage = f"{follower}.get_observation()"
            t_obs = time.perf_counter()
            obs = follower.get_observation()
            slowest = max(slowest, time.perf_counter() - t_obs)
            frames.append({"t": tick - t0, "action": sent, "observation": obs})
            if i >= 30:  # after the follower caught up with the first action
                lag = max(abs(obs[k] - frames[-2]["action"][k]) for k in sent)
                worst = max(worst, lag)
            time.sleep(max(0.0, period - (time.perf_counter() - tick)))
    except Exception as exc:
        rec.add(arm, "-", f"teleoperation loop ({steps} steps)", "FAIL",
                f"step {len(frames)}, in {stage}: {_err(exc)}; slowest get_observation "
                f"before: {slowest * 1e3:.1f} ms; simulator consoles: leader "
                f"{lsim.positions()}, follower {fsim.positions()}")
        return
    elapsed = time.perf_counter() - t0
    # hold the leader still: the follower must settle on the leader's action
    settle: dict[str, float] = {}
    action: dict[str, float] = {}

    def settled() -> bool:
        action.update(leader.get_action())
        follower.send_action(action)
        settle.update(follower.get_observation())
        return all(abs(settle[k] - action[k]) < 1.5 for k in action)

    ok = _wait(settled, 4.0, period)
    rec.check(arm, "-", f"teleoperation loop leader -> follower ({steps} steps)",
              ok and not errors,
              f"{steps / elapsed:.1f} steps/s; slowest get_observation {slowest * 1e3:.1f} ms; "
              f"worst lag {worst:.1f} (normalised units) while "
              "the leader moved; after it stopped: "
              + "; ".join(f"{k} leader {action[k]:.1f} follower {settle[k]:.1f}"
                          for k in action) + (f"; console errors {errors}" if errors else ""))
    keys_ok = all(set(f["observation"]) == set(follower.observation_features)
                  and set(f["action"]) == set(follower.action_features) for f in frames)
    moved = {k: max(f["observation"][k] for f in frames) - min(f["observation"][k]
                                                                for f in frames)
             for k in follower.observation_features}
    still = [k for k, span in moved.items() if span < 5.0 and not (
        kind == "koch" and k.startswith("gripper"))]
    detail = f"{len(frames)} frames; observation span per key {moved}"
    if frames_out is not None:
        frames_out.parent.mkdir(parents=True, exist_ok=True)
        with frames_out.open("w") as fh:
            for f in frames:
                fh.write(json.dumps(f) + "\n")
        detail += f"; written to {frames_out}"
    rec.check(arm, "-", "recorded frames (observation + action per step)",
              len(frames) == steps and keys_ok and not still,
              detail + (f"; keys that never moved: {still}" if still else ""))


# --------------------------------------------------------------------------------------------


class NotBundled(RuntimeError):
    """The config named is neither a file nor a bundled arm of this armctl."""


def _start(armctl: list[str], config: str) -> Sim:
    try:
        return Sim(armctl, config)
    except RuntimeError as exc:
        if "not the name of a bundled arm" in str(exc):
            raise NotBundled(f"{config} is not a bundled arm of this armctl") from exc
        raise


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--armctl", default=shutil.which("armctl") or "armctl",
                        help="the armctl command, from armctl's environment (split like a "
                             "shell line, e.g. '/venv/bin/python -m armctl')")
    parser.add_argument("--feetech", nargs="*", default=["so101", "so101_leader"],
                        help="Feetech arm configs")
    parser.add_argument("--dynamixel", nargs="*", default=None,
                        help="Dynamixel arm configs (default: koch_follower, koch_leader, omx, "
                             "wx250s, those bundled)")
    parser.add_argument("--pairs", nargs="*", default=["so101", "koch"],
                        help="follower/leader pairs for the robot flows")
    parser.add_argument("--so101-leader", default="so101_leader",
                        help="config served as the SO-101 leader (so101 if it is not bundled)")
    parser.add_argument("--steps", type=int, default=300, help="teleoperation steps")
    parser.add_argument("--report", type=Path, help="write the table as Markdown")
    parser.add_argument("--json", type=Path, help="write the steps as JSON")
    parser.add_argument("--frames", type=Path, help="directory for the recorded frames")
    parser.add_argument("--wire-timing", action="store_true",
                        help="run the simulators with --wire-timing")
    args = parser.parse_args(argv)
    Sim.wire_timing = args.wire_timing
    logging.basicConfig(level=logging.WARNING)

    armctl = shlex.split(args.armctl)
    dxl = args.dynamixel
    if dxl is None:
        dxl = ["koch_follower", "koch_leader", "omx", "wx250s"]
    rec = Recorder()
    if TORCH_STAND_IN:
        print("torch is not installed: using the stand-in module (device helpers only)")
    for config in [*args.feetech, *dxl]:
        try:
            sim = _start(armctl, config)
        except NotBundled as exc:
            rec.add(config, "-", "armctl sim", "SKIP", str(exc))
            continue
        except Exception as exc:
            rec.add(config, "-", "armctl sim", "FAIL", _err(exc))
            continue
        try:
            rec.add(config, "-", "armctl sim", "PASS",
                    f"{sim.protocol} on {sim.port} at {sim.baudrate}, ids {sim.ids}")
            bus_flows(rec, sim, config)
        finally:
            sim.stop()
    pair_configs = {"so101": ("so101", args.so101_leader), "koch": ("koch_follower", "koch_leader")}
    for kind in args.pairs:
        fcfg, lcfg = pair_configs[kind]
        frames = args.frames / f"{kind}_frames.jsonl" if args.frames else None
        try:
            robot_flows(rec, armctl, kind, fcfg, lcfg, args.steps, frames)
        except Exception as exc:
            rec.add(f"{kind} pair", "-", "robot flows (stopped)", "FAIL", _err(exc))

    failed = [s for s in rec.steps if s.status == "FAIL"]
    passed = [s for s in rec.steps if s.status == "PASS"]
    print(f"{len(passed)} passed, {len(failed)} failed")
    if args.report:
        args.report.write_text(rec.markdown() + "\n")
    if args.json:
        args.json.write_text(json.dumps([asdict(s) for s in rec.steps], indent=1) + "\n")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
