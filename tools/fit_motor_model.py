"""Fit the simulator's motor model to a real servo's recorded step response.

The simulated servo (``armctl.servo.sim``) drives each shaft with a DC-motor model whose
parameters per model are in ``armctl/servo_tables/motors.py``: the makers' stall torque, stall
current and no-load speed, and assumed values for the mechanical time constant and the friction.
This tool replays a recording of a real servo in the simulator and adjusts four parameters until
the simulated position and current match the recorded ones (least squares, Nelder-Mead with
one restart):

* ``mechanical_time_constant`` [s] (the inertia at the output, rotor included),
* ``no_load_speed`` [rev/min] (at the supply the recording was made at),
* ``stall_current`` [A] (the winding resistance: supply / stall current).

The stall torque stays the maker's (a step response cannot tell the torque constant from the
inertia), and so do the friction figures (``coulomb_fraction``, ``no_load_current``): dry
friction shows only in the last tick or two of a step, below what the encoder resolves; measure
it apart (the smallest Goal PWM that starts the shaft turning, over the stall PWM).

Recording (CSV, one row per sample, a header row first)::

    time,goal,position,current
    0.000,2048,2048,0.004
    0.010,2648,2061,1.512
    ...

``time`` [s] from the start, ``goal`` the Goal Position written [tick] (a step: it changes at
the step's sample), ``position`` the Present Position read [tick], ``current`` the present
current [A] (Dynamixel Present Current x its unit, Feetech Present_Current x 6.5 mA; leave the
column empty on a servo without current sensing). Record with the servo in (single-turn)
position mode at the factory gains, or pass the registers you changed with ``--set``.

Usage::

    python tools/fit_motor_model.py RESPONSE.csv --model xm430-w350 [--set p_gain=900 ...]

prints the fitted parameters as JSON; ``--write-spec`` prints a ``MotorSpec(...)`` line for
motors.py.
"""

from __future__ import annotations

import argparse
import csv
import dataclasses
import json
import math
import sys
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from scipy.optimize import minimize

from armctl.clock import SimulatedClock
from armctl.servo.codec import decode, encode, from_le, to_le
from armctl.servo.sim.servo import SimServo
from armctl.servo_tables import Register, table_for
from armctl.servo_tables.motors import MotorSpec, motor_for

#: The parameters fitted, in the order of the optimiser's vector.
FITTED = ("mechanical_time_constant", "no_load_speed", "stall_current")


@dataclass(frozen=True)
class Recording:
    """A recorded step response.

    Attributes:
        time: Sample times [s].
        goal: Goal Position at each sample [tick].
        position: Present Position [tick].
        current: Present current [A] (NaN where not recorded).
    """

    time: np.ndarray
    goal: np.ndarray
    position: np.ndarray
    current: np.ndarray


def read_csv(path: Path) -> Recording:
    """Read a recording (see the module docstring for the format).

    Raises:
        ValueError: For a file without the four columns, a row that is not numbers, or times
            that do not increase; the message names the file and the line.
    """
    with path.open(newline="", encoding="utf-8") as f:
        rows = list(csv.reader(f))
    if not rows or [c.strip().lower() for c in rows[0][:4]] != ["time", "goal", "position",
                                                                  "current"]:
        raise ValueError(f"{path}: the first line must be the header time,goal,position,current")
    data: list[tuple[float, float, float, float]] = []
    for n, row in enumerate(rows[1:], start=2):
        if not row or not "".join(row).strip():
            continue
        try:
            t, g, p = (float(x) for x in row[:3])
            c = float(row[3]) if len(row) > 3 and row[3].strip() else math.nan
        except ValueError:
            raise ValueError(f"{path}:{n}: expected numbers time,goal,position[,current], got "
                             f"{','.join(row)!r}") from None
        if data and t <= data[-1][0]:
            raise ValueError(f"{path}:{n}: time {t} does not increase")
        data.append((t, g, p, c))
    if len(data) < 10:
        raise ValueError(f"{path}: {len(data)} samples; a step response needs at least 10")
    a = np.array(data)
    return Recording(a[:, 0] - a[0, 0], a[:, 1], a[:, 2], a[:, 3])


def write_csv(path: Path, rec: Recording) -> None:
    """Write a recording in the format :func:`read_csv` reads."""
    with path.open("w", newline="", encoding="utf-8") as f:
        w = csv.writer(f)
        w.writerow(["time", "goal", "position", "current"])
        for t, g, p, c in zip(rec.time, rec.goal, rec.position, rec.current, strict=True):
            w.writerow([f"{t:.4f}", int(g), int(p), "" if math.isnan(c) else f"{c:.4f}"])


def _write(servo: SimServo, reg: Register, value: int) -> None:
    spec = servo.table.spec(reg)
    err = servo.write(spec.address, to_le(encode(spec, value), spec.size))
    if err or servo.get(reg) != value:
        raise ValueError(f"the {servo.table.model} refuses {reg.value} = {value}")


def _read(servo: SimServo, reg: Register) -> int:
    spec = servo.table.spec(reg)
    raw = servo.read(spec.address, spec.size)
    assert raw is not None
    return decode(spec, from_le(raw))


def simulate(model: str, motor: MotorSpec, time: Iterable[float], goal: Iterable[float],
             start: float, settings: dict[Register, int] | None = None) -> Recording:
    """The simulated servo's response to a goal sequence, sampled at ``time``.

    Args:
        model: Servo model.
        motor: Motor parameters to simulate.
        time: Sample times [s] (increasing, from 0).
        goal: Goal Position at each sample [tick].
        start: Present position at time 0 [tick].
        settings: Registers set (torque off) before the recording, e.g. gains.
    """
    table = table_for(model)
    clock = SimulatedClock()
    servo = SimServo(table, 1, next(iter(table.vendor.baud_codes.values())), round(start),
                     clock=clock)
    servo.use_motor(motor)
    if table.vendor.feetech:
        _write(servo, Register.LOCK, 0)
    for reg, value in (settings or {}).items():
        _write(servo, reg, value)
    _write(servo, Register.TORQUE_ENABLE, 1)
    unit = motor.current_unit
    pos: list[float] = []
    cur: list[float] = []
    times, goals = list(time), list(goal)
    last_goal = None
    t0 = clock.now()
    for t, g in zip(times, goals, strict=True):
        clock.sleep_until(t0 + t)
        if g != last_goal:
            _write(servo, Register.GOAL_POSITION, round(g))
            last_goal = g
        pos.append(_read(servo, Register.PRESENT_POSITION))
        if table.vendor.feetech and unit is not None:
            cur.append(_read(servo, Register.PRESENT_CURRENT) * unit
                       * (1 if _read(servo, Register.PRESENT_LOAD) >= 0 else -1))
        elif unit is not None:
            cur.append(_read(servo, Register.PRESENT_LOAD) * unit)
        else:
            cur.append(_read(servo, Register.PRESENT_LOAD) / 1000.0 * motor.stall_current)
    return Recording(np.asarray(times, float), np.asarray(goals, float),
                     np.asarray(pos, float), np.asarray(cur, float))


def with_params(base: MotorSpec, values: Iterable[float]) -> MotorSpec:
    """``base`` with the :data:`FITTED` parameters replaced by ``values``."""
    changes: dict[str, Any] = dict(zip(FITTED, (float(v) for v in values), strict=True))
    return dataclasses.replace(base, **changes)


def residual(rec: Recording, sim: Recording) -> float:
    """Mean squared mismatch: position in units of the largest step, current in A/stall."""
    span = max(1.0, float(np.ptp(rec.goal)), float(np.ptp(rec.position)))
    ep = (sim.position - rec.position) / span
    err = float(np.mean(ep * ep))
    have = ~np.isnan(rec.current)
    if have.any():
        scale = max(1e-3, float(np.max(np.abs(rec.current[have]))))
        ec = (sim.current[have] - rec.current[have]) / scale
        err += float(np.mean(ec * ec))
    return err


def fit(model: str, rec: Recording, settings: dict[Register, int] | None = None,
        start_from: MotorSpec | None = None) -> tuple[MotorSpec, float]:
    """Fit the :data:`FITTED` parameters of ``model``'s motor to a recording.

    Returns:
        The fitted motor parameters and the final residual (see :func:`residual`).
    """
    base = start_from if start_from is not None else motor_for(model)
    x0 = np.array([getattr(base, name) for name in FITTED])

    def cost(logx: np.ndarray) -> float:
        spec = with_params(base, x0 * np.exp(logx))
        sim = simulate(model, spec, rec.time, rec.goal, rec.position[0], settings)
        return residual(rec, sim)

    x = np.zeros(len(FITTED))
    fun = math.inf
    for step in (0.3, 0.05):  # a restart from the best point: quantised ticks make the
        best = minimize(cost, x, method="Nelder-Mead",  # cost surface rough
                        options={"xatol": 1e-3, "fatol": 1e-10, "maxiter": 400,
                                 "initial_simplex": _simplex(x, step)})
        if best.fun < fun:
            x, fun = best.x, float(best.fun)
    return with_params(base, x0 * np.exp(x)), fun


def _simplex(x: np.ndarray, step: float) -> np.ndarray:
    """A starting simplex at ``x`` with sides ``step`` (log scale: 0.3 is +35 %)."""
    pts = [x.copy()]
    for i in range(len(x)):
        p = x.copy()
        p[i] += step
        pts.append(p)
    return np.array(pts)


def _settings(items: Sequence[str]) -> dict[Register, int]:
    out = {}
    for item in items:
        name, sep, value = item.partition("=")
        if not sep:
            raise SystemExit(f"--set {item!r}: expected REGISTER=VALUE, e.g. p_gain=900")
        try:
            out[Register.parse(name)] = int(value)
        except ValueError:
            raise SystemExit(f"--set {item!r}: the value must be an integer") from None
    return out


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("csv", type=Path, help="recorded step response (time,goal,position,"
                        "current)")
    parser.add_argument("--model", required=True, help="servo model, e.g. xm430-w350")
    parser.add_argument("--set", action="append", default=[], metavar="REG=VALUE",
                        help="a register that differed from its factory value while recording")
    parser.add_argument("--write-spec", action="store_true",
                        help="also print the fitted MotorSpec(...) for motors.py")
    args = parser.parse_args(argv)
    try:
        rec = read_csv(args.csv)
    except (OSError, ValueError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    base = motor_for(args.model)
    spec, res = fit(args.model, rec, _settings(args.set))
    out = {name: getattr(spec, name) for name in FITTED}
    out["datasheet"] = {name: getattr(base, name) for name in FITTED}
    out["residual"] = res
    print(json.dumps(out, indent=2))
    if args.write_spec:
        print(repr(spec))
    return 0


if __name__ == "__main__":
    sys.exit(main())
