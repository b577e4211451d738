"""Shared fixtures."""

from __future__ import annotations

import os
from collections.abc import Iterator
from pathlib import Path

import pytest
from armctl_testpaths import DATA

from armctl.clock import SimulatedClock, set_default_clock


@pytest.fixture
def data_dir() -> Path:
    return DATA


@pytest.hookimpl(tryfirst=True)
def pytest_cmdline_main(config: pytest.Config) -> None:
    """A run of the whole suite (no paths given) uses one pytest-xdist worker per core.

    Only when pytest-xdist is installed (the test extra), the machine has two cores or more and
    neither ``-n`` (``-n 0``: this process only), ``--pdb`` nor ``--collect-only`` is given; a run
    of chosen files or tests stays in this process. Runs before xdist's own hook.
    """
    if hasattr(config, "workerinput") or not config.pluginmanager.hasplugin("xdist"):
        return
    if config.args_source is not pytest.Config.ArgsSource.TESTPATHS or (os.cpu_count() or 1) < 2:
        return
    if (config.option.numprocesses is not None or config.getoption("usepdb", False)
            or config.option.collectonly):
        return
    config.option.numprocesses = "auto"


def pytest_configure(config: pytest.Config) -> None:
    config.addinivalue_line(
        "markers", "realtime: runs motion in wall-clock time (an end-to-end check of the real "
        "time base); without it the robot tests run in simulated time")


@pytest.fixture
def simulated_time(request: pytest.FixtureRequest) -> Iterator[SimulatedClock | None]:
    """Everything the test opens (robot, executor, simulated bus) runs on one simulated clock.

    A test marked ``realtime`` keeps the wall clock (the fixture yields ``None`` then).
    """
    if request.node.get_closest_marker("realtime") is not None:
        yield None
        return
    clock = SimulatedClock()
    previous = set_default_clock(clock)
    try:
        yield clock
    finally:
        set_default_clock(previous)


@pytest.fixture(autouse=True, scope="session")
def _calibrations_outside_home(tmp_path_factory: pytest.TempPathFactory) -> Iterator[None]:
    """The bundled arms' calibrations go to a temporary ARMCTL_HOME (subprocesses inherit it)."""
    import os

    previous = os.environ.get("ARMCTL_HOME")
    os.environ["ARMCTL_HOME"] = str(tmp_path_factory.mktemp("armctl_home"))
    try:
        yield
    finally:
        if previous is None:
            os.environ.pop("ARMCTL_HOME", None)
        else:
            os.environ["ARMCTL_HOME"] = previous
