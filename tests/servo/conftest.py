from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest

from armctl.config import load_spec
from armctl.config.bus import Protocol
from armctl.config.schema import ArmSpec
from armctl.servo import ServoBus, SimServoSpec, SimulatedBus

DATA = Path(__file__).parent / "data"


@pytest.fixture
def so_spec() -> ArmSpec:
    return load_spec(DATA / "so_sim.yaml")


@pytest.fixture
def dxl_spec() -> ArmSpec:
    return load_spec(DATA / "dxl_sim.yaml")


def open_pair(servos: list[SimServoSpec], protocol: Protocol, retries: int = 2
              ) -> tuple[SimulatedBus, ServoBus]:
    sim = SimulatedBus(servos, protocol, 1_000_000)
    sim.start()
    bus = ServoBus(sim.port, protocol, 1_000_000, models={s.servo_id: s.model for s in servos},
                   retries=retries, latency_ms=8.0)
    bus.open()
    return sim, bus


@pytest.fixture
def dxl_pair() -> Iterator[tuple[SimulatedBus, ServoBus]]:
    sim, bus = open_pair([SimServoSpec(1, "xl330-m288"), SimServoSpec(2, "xl430-w250"),
                          SimServoSpec(3, "xm430-w350")], Protocol.DYNAMIXEL)
    yield sim, bus
    bus.close()
    sim.stop()


@pytest.fixture
def ft_pair() -> Iterator[tuple[SimulatedBus, ServoBus]]:
    sim, bus = open_pair([SimServoSpec(i, "sts3215") for i in (1, 2, 3)], Protocol.FEETECH)
    yield sim, bus
    bus.close()
    sim.stop()
