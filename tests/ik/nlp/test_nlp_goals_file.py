import math
from pathlib import Path

import numpy as np
import pytest

from armctl.config.source import parse_yaml
from armctl.errors import ConfigError
from armctl.ik import DirectionGoal, PoseGoal, PositionGoal
from armctl.ik.nlp import (
    AxisInCone,
    InBox,
    InHalfSpace,
    KeepOutBox,
    KeepOutSphere,
    NLPOptions,
    OnPlane,
)
from armctl.ik.nlp.goals_file import load_goals, parse_goals

GOALS = """\
goals:
  - {type: pose, frame: flange, position: [0.4, 0.1, 0.3], rpy: [180 deg, 0, 0]}
  - {type: direction, frame: l5, position: [0.4, 0, 0.2], direction: [0, 0, -2]}
constraints:
  - {type: plane, point: [0, 0, 0.2], normal: [0, 0, 1]}
  - {type: halfspace, point: [0, 0, 0.05], normal: [0, 0, 1], weight: 10}
  - {type: box, lower: [0, -0.5, 0], upper: [0.6, 0.5, 0.8]}
  - {type: cone, direction: [0, 0, -1], half_angle: 20 deg}
  - {type: keep_out_sphere, center: [0.3, 0.2, 0.3], radius: 0.1}
  - {type: keep_out_box, lower: [0.2, -0.1, 0], upper: [0.4, 0.1, 0.15], link_radius: 0.05}
"""


def test_parse_every_kind(tmp_path: Path):
    f = tmp_path / "goals.yaml"
    f.write_text(GOALS)
    doc = load_goals(f)
    pose, direction = doc.goals
    assert isinstance(pose, PoseGoal) and pose.frame == "flange"
    np.testing.assert_allclose(pose.rotation, np.diag([1.0, -1.0, -1.0]), atol=1e-12)
    assert isinstance(direction, DirectionGoal)
    np.testing.assert_allclose(direction.direction, [0, 0, -1])
    kinds = [type(c) for c in doc.constraints]
    assert kinds == [OnPlane, InHalfSpace, InBox, AxisInCone, KeepOutSphere, KeepOutBox]
    assert doc.constraints[0].hard and not doc.constraints[1].hard
    assert doc.constraints[1].weight == 10
    assert math.isclose(doc.constraints[3].half_angle, math.radians(20))
    assert doc.constraints[5].link_radius == 0.05
    assert doc.constraints[4].link_radius is None  # absent: default shapes sized by the arm


@pytest.mark.parametrize(("text", "line", "words"), [
    ("goals:\n  - {type: pose, position: [0, 0, 0]}\n", 2, "rpy"),
    ("goals:\n  - {type: positon, position: [0, 0, 0]}\n", 2, "position"),
    ("goals:\n  - {type: position, position: [0, 0]}\n", 2, "3 numbers"),
    ("goals:\n  - {type: position, position: [0, 0, 1]}\nconstraints:\n"
     "  - {type: plane, point: [0, 0, 0], normal: [0, 0, 0]}\n", 4, "zero vector"),
    ("goals:\n  - {type: position, position: [0, 0, 1]}\nconstraints:\n"
     "  - {type: sphere, center: [0, 0, 0], radius: -1}\n", 4, "greater than zero"),
    ("goals: []\n", 1, "empty"),
])
def test_errors_name_line_and_problem(text, line, words):
    with pytest.raises(ConfigError) as info:
        parse_goals(parse_yaml(text, Path("g.yaml")))
    msg = str(info.value)
    assert f"g.yaml:{line}" in msg
    assert words in msg


def test_goals_file_solves_with_nlp(ur5e, tmp_path: Path):
    q = ur5e.sample(np.random.default_rng(2))
    p = ur5e.fk(q)[:3, 3]
    f = tmp_path / "goals.yaml"
    f.write_text(f"goals:\n  - {{type: position, position: [{p[0]}, {p[1]}, {p[2]}]}}\n"
                 f"constraints:\n  - {{type: plane, point: [0, 0, {p[2]}], normal: [0, 0, 1]}}\n")
    doc = load_goals(f)
    assert isinstance(doc.goals[0], PositionGoal)
    res = ur5e.ik(doc.goals, solver="nlp", constraints=doc.constraints,
                  options=NLPOptions(time_limit=1.0))
    assert res.success, res.message
    assert abs(ur5e.fk(res.q)[2, 3] - p[2]) <= 1e-5
