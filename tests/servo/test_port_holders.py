"""Which processes have a port open, read from a proc file system (a made-up one, the real one)."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from armctl.servo.port_holders import PortHolder, port_holders


def _process(proc: Path, pid: int, argv: list[str], fds: dict[str, str]) -> None:
    d = proc / str(pid)
    (d / "fd").mkdir(parents=True)
    (d / "cmdline").write_bytes(b"\0".join(a.encode() for a in argv) + b"\0")
    for fd, target in fds.items():
        (d / "fd" / fd).symlink_to(target)


def test_holders_from_a_proc_tree(tmp_path: Path) -> None:
    port = tmp_path / "ttyACM0"
    port.write_text("")
    link = tmp_path / "by-id"
    link.symlink_to(port)
    proc = tmp_path / "proc"
    _process(proc, 40, ["minicom", "-D", str(port)], {"0": "/dev/null", "3": str(port)})
    _process(proc, 41, ["/usr/bin/python3", "-m", "armctl", "play", "so101", "p.yaml"],
             {"5": str(port)})
    _process(proc, 42, ["/venv/bin/python", "/venv/bin/armctl", "status", "so101"],
             {"4": str(port)})
    _process(proc, 43, ["bash"], {"0": "/dev/pts/9"})  # not the port
    _process(proc, os.getpid(), ["me"], {"7": str(port)})  # this process is left out
    (proc / "self").mkdir()  # not a pid
    found = port_holders(str(link), proc)
    assert found == [PortHolder(40, f"minicom -D {port}"),
                     PortHolder(41, "armctl play so101 p.yaml"),
                     PortHolder(42, "armctl status so101")]
    assert [h.is_armctl for h in found] == [False, True, True]
    assert str(found[0]) == f"pid 40: minicom -D {port}"
    assert port_holders(str(tmp_path / "other"), proc) == []
    assert port_holders(str(port), tmp_path / "no-proc") == []


@pytest.mark.skipif(not Path("/proc/self/fd").is_dir(), reason="needs Linux's /proc")
def test_a_real_process_holding_a_file(tmp_path: Path) -> None:
    held = tmp_path / "held"
    held.write_text("")
    child = subprocess.Popen([sys.executable, "-c",
                              f"f = open({str(held)!r}); print('open', flush=True); input()"],
                             stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
    try:
        assert child.stdout is not None and child.stdout.readline().strip() == "open"
        found = port_holders(str(held))
    finally:
        child.communicate("\n", timeout=10)
    assert [h.pid for h in found] == [child.pid]
    assert found[0].command.startswith(sys.executable) and not found[0].is_armctl
