from pathlib import Path

import pytest

from armctl.arm import Arm, load_arm

DATA = Path(__file__).parent / "data"
PLANAR = Path(__file__).parents[2] / "data" / "planar3r.yaml"


@pytest.fixture(scope="session")
def ur5e() -> Arm:
    return load_arm(DATA / "ur5e.yaml")


@pytest.fixture(scope="session")
def panda() -> Arm:
    return load_arm(DATA / "panda.yaml")


@pytest.fixture(scope="session")
def twoarm() -> Arm:
    return load_arm(DATA / "twoarm.yaml")


@pytest.fixture(scope="session")
def planar() -> Arm:
    return load_arm(PLANAR)
