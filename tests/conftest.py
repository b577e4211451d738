"""Shared fixtures: paths to test data and the bundled arms."""

from __future__ import annotations

from pathlib import Path

import pytest

DATA = Path(__file__).parent / "data"
REPO = Path(__file__).parent.parent
CONFIGS = REPO / "configs"

#: Every bundled arm; a missing file fails the tests that use it.
BUNDLED = ("so101", "omx", "wx250s", "ur5e", "panda", "torso")
#: Bundled arms that have an independent reference URDF in tests/data/urdf.
WITH_URDF = ("so101", "omx", "wx250s", "ur5e", "panda")


@pytest.fixture
def data_dir() -> Path:
    return DATA
