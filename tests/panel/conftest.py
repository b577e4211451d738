"""The panel tests run motion in simulated time unless marked ``realtime``."""

from __future__ import annotations

import pytest


@pytest.fixture(autouse=True)
def _panel_simulated_time(simulated_time: object) -> None:
    """Use the shared ``simulated_time`` fixture for every test here."""
