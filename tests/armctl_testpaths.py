"""Paths of the test data and the bundled arms, shared by the test modules.

(A plain module rather than conftest.py: several test folders have a conftest.py of their own,
and importing one of them by name would pick whichever comes first on sys.path.)
"""

from __future__ import annotations

from pathlib import Path

DATA = Path(__file__).parent / "data"
REPO = Path(__file__).parent.parent
CONFIGS = REPO / "configs"

#: Every bundled arm; a missing file fails the tests that use it.
BUNDLED = ("so101", "omx", "wx250s", "ur5e", "panda", "torso", "so101_leader", "koch_follower",
           "koch_leader")
#: Bundled arms that have an independent reference URDF in tests/data/urdf.
WITH_URDF = ("so101", "omx", "wx250s", "ur5e", "panda")
