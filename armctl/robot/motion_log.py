"""Per-cycle motion logs: what each streaming cycle commanded and measured, as a CSV file.

The executor keeps the planned time, the command and the measurement of every cycle when asked
to record (:attr:`armctl.robot.executor.StreamResult.log_t` and friends); this module turns
them into a :class:`MotionLog`, writes it atomically and reads it back. The file::

    # armctl motion log; arm=so101; rate_hz=50; units=SI; joints=shoulder_pan:revolute,...
    t,shoulder_pan_cmd,shoulder_pan_meas,...
    0.000000,0.0000000,0.0000000,...

``t`` is the planned time of the cycle [s] from the start of the first motion (the motions of
one command follow one another on one time axis); ``<joint>_cmd`` and ``<joint>_meas`` are the
commanded and measured joint values in [rad] (revolute joints) or [m] (prismatic joints).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from armctl.atomic_write import write_atomic
from armctl.errors import ConfigError, KeyPath

__all__ = ["MotionLog", "check_log_target", "read_log", "tracking_errors", "write_log"]

Array = npt.NDArray[np.float64]

#: The first word of the comment line that opens a motion log.
MARK = "# armctl motion log"

#: Joint kinds a log names.
KINDS = ("revolute", "prismatic")


@dataclass(frozen=True)
class MotionLog:
    """The cycles of one command's motions.

    Attributes:
        arm: Name of the arm.
        rate_hz: Streaming rate [Hz].
        joints: Names of the logged (bus) joints.
        prismatic: Per joint, whether it is prismatic ([m]) rather than revolute ([rad]).
        t: Planned time of each cycle ``(N,)`` [s].
        cmd: Commanded joint values ``(N, J)`` [rad]/[m].
        meas: Measured joint values ``(N, J)`` [rad]/[m].
    """

    arm: str
    rate_hz: float
    joints: tuple[str, ...]
    prismatic: tuple[bool, ...]
    t: Array
    cmd: Array
    meas: Array

    @property
    def error(self) -> Array:
        """Tracking error, measured minus commanded ``(N, J)`` [rad]/[m]."""
        return self.meas - self.cmd

    def to_text(self) -> str:
        """The CSV text of the log (see the module docstring)."""
        kinds = ",".join(f"{n}:{KINDS[int(p)]}" for n, p in zip(self.joints, self.prismatic,
                                                                  strict=True))
        lines = [f"{MARK}; arm={self.arm}; rate_hz={self.rate_hz:g}; units=SI; joints={kinds}",
                 ",".join(["t", *(f"{n}_{w}" for n in self.joints for w in ("cmd", "meas"))])]
        for i in range(self.t.size):
            vals = [f"{self.t[i]:.6f}"]
            for j in range(len(self.joints)):
                vals += [f"{self.cmd[i, j]:.9g}", f"{self.meas[i, j]:.9g}"]
            lines.append(",".join(vals))
        return "\n".join(lines) + "\n"


def check_log_target(path: str | Path) -> Path:
    """Refuse a log file that exists, whose folder is missing or not named ``.csv``.

    Checked before anything moves.

    Raises:
        ConfigError: The file exists (a log is never overwritten), its folder is missing, or
            its name does not end in ``.csv`` (the log is CSV; another suffix is most often a
            mix-up with a keyframe file or a picture).
    """
    p = Path(path)
    if p.suffix.lower() != ".csv":
        raise ConfigError(f"a motion log is a CSV file, but {p.name!r} does not end in '.csv'; "
                          "nothing was moved", KeyPath(p),
                          f"name it {p.stem or 'motion'}.csv (keyframes are written with -o)")
    if p.exists():
        raise ConfigError("the motion log file already exists; nothing was moved", KeyPath(p),
                          "choose another name, or delete the old log first")
    folder = p.parent if str(p.parent) else Path(".")
    if not folder.is_dir():
        raise ConfigError(f"the folder {str(folder)!r} of the motion log does not exist; nothing "
                          "was moved", KeyPath(p), "create the folder or choose another path")
    return p


def write_log(path: str | Path, log: MotionLog) -> Path:
    """Write a motion log atomically (a temporary file and a rename).

    Raises:
        ConfigError: The file cannot be written.
    """
    return write_atomic(path, log.to_text())


def tracking_errors(log: MotionLog) -> dict[str, dict[str, Any]]:
    """Per joint: the largest and the RMS tracking error, in [deg] or [mm].

    Returns:
        ``{joint: {"unit": "deg"|"mm", "max": float, "rms": float}}``.
    """
    out: dict[str, dict[str, Any]] = {}
    err = log.error
    for j, name in enumerate(log.joints):
        scale, unit = (1000.0, "mm") if log.prismatic[j] else (math.degrees(1.0), "deg")
        e = np.abs(err[:, j]) * scale
        out[name] = {"unit": unit, "max": float(e.max()),
                     "rms": float(np.sqrt(np.mean(e ** 2)))}
    return out


def _bad(path: Path, line: int, problem: str, fix: str) -> ConfigError:
    return ConfigError(problem, KeyPath(path, line=line), fix)


def _parse_header(path: Path, first: str) -> tuple[str, float, dict[str, bool]]:
    fix = ("a motion log starts with the comment line written by '--log' "
           f"('{MARK}; arm=...; rate_hz=...; units=SI; joints=NAME:revolute,...')")
    if not first.startswith(MARK):
        raise _bad(path, 1, f"not an armctl motion log: line 1 is not {MARK!r}", fix)
    fields: dict[str, str] = {}
    for part in first[len(MARK):].split(";"):
        if part.strip():
            key, sep, value = part.partition("=")
            if not sep:
                raise _bad(path, 1, f"header item {part.strip()!r} is not KEY=VALUE", fix)
            fields[key.strip()] = value.strip()
    missing = [k for k in ("arm", "rate_hz", "units", "joints") if k not in fields]
    if missing:
        raise _bad(path, 1, f"the header lacks {', '.join(missing)}", fix)
    if fields["units"] != "SI":
        raise _bad(path, 1, f"units {fields['units']!r} are not SI", fix)
    try:
        rate = float(fields["rate_hz"])
    except ValueError:
        raise _bad(path, 1, f"rate_hz {fields['rate_hz']!r} is not a number", fix) from None
    if not math.isfinite(rate) or rate <= 0:
        raise _bad(path, 1, f"rate_hz {fields['rate_hz']!r} must be more than 0", fix)
    kinds: dict[str, bool] = {}
    for item in fields["joints"].split(","):
        name, _, kind = item.strip().partition(":")
        if not name or kind not in KINDS or name in kinds:
            raise _bad(path, 1, f"joint entry {item.strip()!r} is not NAME:revolute or "
                       "NAME:prismatic (or repeats a joint)", fix)
        kinds[name] = kind == "prismatic"
    return fields["arm"], rate, kinds


def read_log(path: str | Path) -> MotionLog:
    """Read a motion log written by :func:`write_log`.

    Raises:
        ConfigError: A missing or unreadable file, or a garbled one (with the line and a fix):
            no header comment, columns that do not match its joints, a row with the wrong number
            of values, a value that is not a finite number, times that go backwards, no rows.
    """
    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise ConfigError("the motion log does not exist", KeyPath(p),
                          "check the path (a log is written by a motion verb's '--log FILE.csv')"
                          ) from None
    except (OSError, UnicodeDecodeError) as exc:
        raise ConfigError(f"cannot read the motion log: {exc}", KeyPath(p),
                          "check that it is a readable text file") from None
    lines = text.splitlines()
    if not lines:
        raise _bad(p, 1, "the motion log is empty", "log a motion with '--log FILE.csv'")
    arm, rate, kinds = _parse_header(p, lines[0])
    names = tuple(kinds)
    want = ["t", *(f"{n}_{w}" for n in names for w in ("cmd", "meas"))]
    columns = lines[1].split(",") if len(lines) > 1 else []
    if [c.strip() for c in columns] != want:
        raise _bad(p, 2, f"the column names do not match the header's joints (expected "
                   f"{','.join(want)})", "do not edit the columns of a motion log by hand")
    rows: list[list[float]] = []
    for no, line in enumerate(lines[2:], start=3):
        if not line.strip():
            continue
        cells = line.split(",")
        if len(cells) != len(want):
            raise _bad(p, no, f"{len(cells)} values where the header has {len(want)} columns",
                       "remove or repair the truncated line")
        try:
            vals = [float(c) for c in cells]
        except ValueError:
            raise _bad(p, no, "a value is not a number", "remove or repair the line") from None
        if not all(math.isfinite(v) for v in vals):
            raise _bad(p, no, "a value is not finite", "remove or repair the line")
        if rows and vals[0] < rows[-1][0]:
            raise _bad(p, no, f"time {vals[0]:g} s goes back from {rows[-1][0]:g} s",
                       "keep the rows in time order")
        rows.append(vals)
    if not rows:
        raise _bad(p, len(lines), "the motion log has no cycles",
                   "log a motion that moved the arm")
    data = np.array(rows, dtype=float)
    return MotionLog(arm, rate, names, tuple(kinds.values()), data[:, 0],
                     data[:, 1::2].copy(), data[:, 2::2].copy())
