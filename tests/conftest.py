"""Shared fixtures."""

from __future__ import annotations

from pathlib import Path

import pytest
from armctl_testpaths import DATA


@pytest.fixture
def data_dir() -> Path:
    return DATA
