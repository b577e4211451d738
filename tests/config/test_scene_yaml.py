"""The scene: and collision: sections, scene files, writing them and replacing the matrix."""

from __future__ import annotations

import math
import re
from pathlib import Path

import pytest
from armctl_testpaths import BUNDLED, CONFIGS, REPO

import armctl
from armctl.config.arm_yaml import load_arm_yaml, parse_arm
from armctl.config.collision_writer import replace_collision_section, with_collision_section
from armctl.config.scene import (
    TABLE,
    AllowedPair,
    AllowReason,
    CollisionSpec,
    Obstacle,
    SceneFrame,
    SceneSpec,
    TableSpec,
)
from armctl.config.scene_yaml import load_scene
from armctl.config.schema import Box, Capsule, Cylinder, Mesh, Origin, Sphere
from armctl.config.source import parse_yaml
from armctl.config.writer import dump_arm_yaml, dump_scene_yaml, merge_fixed
from armctl.errors import ConfigError

ARM = """\
# a test arm
armctl: 1
name: t
base: base
joints:
  - name: j1
    type: revolute
    parent: base
    child: l1
    limits: {lower: -1, upper: 1}
  - name: j2
    type: revolute
    parent: l1
    child: l2
    origin: {xyz: [0.1, 0, 0]}
    limits: {lower: -1, upper: 1}
links:
  - name: l1
    collision:
      - {shape: capsule, radius: 0.02, length: 0.1}
"""
ARM_LINES = ARM.count("\n")  # the sections below start on line ARM_LINES + 1

SCENE = """\
scene:
  table: {height: -0.01}
  padding: 0.01
  base_in_world: {xyz: [0.4, 0.3, 0.75], rpy: [0, 0, "90 deg"]}
  obstacles:
    - name: wall
      shape: box
      size: [0.02, 0.4, 0.3]
      origin: {xyz: [0.25, 0, 0.15], rpy: [0, 0, 0.5]}
    - {name: ball, shape: sphere, radius: 0.05, frame: world}
    - {name: can, shape: cylinder, radius: 0.04, length: 0.1, frame: base}
    - {name: post, shape: capsule, radius: 0.01, length: 0.3}
    - {name: rock, shape: mesh, path: meshes/rock.stl, scale: [0.001, 0.001, 0.001]}
"""

COLLISION = """\
collision:
  samples: 1000
  allowed:
    - {links: [base, l1], reason: adjacent}
    - {links: [l1, l2], reason: always, note: "overlap in 100% of samples"}
    - links: [l2, table]
      reason: user
      note: the gripper may touch the table
"""


def write(tmp_path: Path, text: str, name: str = "arm.yaml") -> Path:
    (tmp_path / "meshes").mkdir(exist_ok=True)
    (tmp_path / "meshes" / "rock.stl").write_text("solid rock\nendsolid rock\n")
    p = tmp_path / name
    p.write_text(text)
    return p


def expect(tmp_path: Path, text: str, line: int, key: str, *fragments: str,
           name: str = "arm.yaml") -> ConfigError:
    """Loading ``text`` fails at ``line`` and ``key``, naming the file and ``fragments``."""
    p = write(tmp_path, text, name)
    with pytest.raises(ConfigError) as info:
        load_scene(p) if name != "arm.yaml" else load_arm_yaml(p)
    err = info.value
    msg = str(err)
    assert msg.startswith(f"{p}:{line}: {key}: "), msg
    assert err.where.line == line and err.where.dotted() == key, (err.where, msg)
    for frag in fragments:
        assert frag in msg, (frag, msg)
    return err


# ---- reading -----------------------------------------------------------------------------------


def test_sections_are_read(tmp_path: Path) -> None:
    spec = load_arm_yaml(write(tmp_path, ARM + SCENE + COLLISION))
    scene, col = spec.scene, spec.collision
    assert scene is not None and col is not None
    assert scene.table == TableSpec(-0.01)
    assert scene.padding == 0.01
    assert scene.base_in_world == Origin((0.4, 0.3, 0.75), (0.0, 0.0, math.pi / 2))
    assert scene.file is None
    assert [o.name for o in scene.obstacles] == ["wall", "ball", "can", "post", "rock"]
    wall, ball, can, post, rock = scene.obstacles
    assert wall == Obstacle("wall", Box((0.02, 0.4, 0.3), Origin((0.25, 0, 0.15), (0, 0, 0.5))))
    assert ball == Obstacle("ball", Sphere(0.05), SceneFrame.WORLD)
    assert can == Obstacle("can", Cylinder(0.04, 0.1), SceneFrame.BASE)
    assert post.shape == Capsule(0.01, 0.3)
    assert isinstance(rock.shape, Mesh)
    assert rock.shape.path == tmp_path / "meshes" / "rock.stl"  # relative to the arm file
    assert rock.shape.scale == (0.001, 0.001, 0.001)
    assert wall.where.line == ARM_LINES + 6 and wall.where.label == "wall"
    assert scene.table is not None and scene.table.where.line == ARM_LINES + 2
    assert col.samples == 1000
    assert [(p.a, p.b, p.reason, p.note) for p in col.allowed] == [
        ("base", "l1", AllowReason.ADJACENT, ""),
        ("l1", "l2", AllowReason.ALWAYS, "overlap in 100% of samples"),
        ("l2", TABLE, AllowReason.USER, "the gripper may touch the table"),
    ]
    assert [p.where.line for p in col.allowed] == [ARM_LINES + SCENE.count("\n") + i
                                                    for i in (4, 5, 6)]
    assert col.allowed[2].where.label == "l2 / table"


def test_absent_sections_are_none(tmp_path: Path) -> None:
    spec = load_arm_yaml(write(tmp_path, ARM))
    assert spec.scene is None and spec.collision is None
    empty = load_arm_yaml(write(tmp_path, ARM + "scene: {}\ncollision: {}\n"))
    assert empty.scene == SceneSpec()  # the defaults: a table at 0, 5 mm, nothing else
    assert empty.collision == CollisionSpec()


def test_bundled_arm_still_loads() -> None:
    arm = armctl.load_arm("so101")
    assert arm.joint_names


@pytest.mark.parametrize(("table", "expected"), [
    ("false", None), ("none", None), ("true", TableSpec(0.0)), ("{}", TableSpec(0.0)),
    ("{height: 0.02}", TableSpec(0.02)), ("{height: -1e-2}", TableSpec(-0.01)),
])
def test_table_forms(tmp_path: Path, table: str, expected: TableSpec | None) -> None:
    spec = load_arm_yaml(write(tmp_path, ARM + f"scene:\n  table: {table}\n"))
    assert spec.scene is not None and spec.scene.table == expected


def test_scene_file(tmp_path: Path) -> None:
    sub = tmp_path / "scenes"
    sub.mkdir()
    (sub / "meshes").mkdir()
    (sub / "meshes" / "rock.stl").write_text("solid\nendsolid\n")
    body = "\n".join(line[2:] for line in SCENE.splitlines()[1:]) + "\n"
    p = sub / "scene.yaml"
    p.write_text("armctl: 1\n" + body)
    scene = load_scene(p)
    from_section = load_arm_yaml(write(tmp_path, ARM + SCENE)).scene
    assert scene.file == p
    assert scene.obstacles[-1].shape == Mesh(sub / "meshes" / "rock.stl", (0.001,) * 3)
    assert from_section is not None
    assert scene.obstacles[:-1] == from_section.obstacles[:-1]
    assert (scene.table, scene.padding, scene.base_in_world) == (
        from_section.table, from_section.padding, from_section.base_in_world)
    assert scene.obstacles[0].where.file == p and scene.obstacles[0].where.line == 6


def test_scene_file_checks_link_names(tmp_path: Path) -> None:
    p = write(tmp_path, "obstacles:\n  - {name: l1, shape: sphere, radius: 0.1}\n", "s.yaml")
    assert load_scene(p).obstacles[0].name == "l1"  # no arm given: not checked
    with pytest.raises(ConfigError, match="obstacle 'l1' has the name of a link") as info:
        load_scene(p, links=["base", "l1", "l2"])
    assert info.value.where.line == 2 and info.value.where.dotted() == "obstacles[0] (l1).name"


# ---- errors ------------------------------------------------------------------------------------

S = ARM_LINES  # line of 'scene:' is S + 1
C = ARM_LINES + SCENE.count("\n")  # line of 'collision:' is C + 1


@pytest.mark.parametrize(("old", "new", "line", "key", "fragments"), [
    ("  padding: 0.01", "  paddin: 0.01", S + 3, "scene.paddin",
     ["unknown key 'paddin'", "did you mean 'padding'?"]),
    ("  padding: 0.01", "  padding: -0.01", S + 3, "scene.padding", ["must not be negative"]),
    ("  padding: 0.01", "  padding: 5", S + 3, "scene.padding",
     ["padding 5 m is more than 0.2 m", "did you mean 0.005 m (5 mm)?"]),
    ("  padding: 0.01", "  padding: 0.25", S + 3, "scene.padding", ["more than 0.2 m"]),
    ("  padding: 0.01", "  padding: '5 mm'", S + 3, "scene.padding", ["expected a number"]),
    ("  table: {height: -0.01}", "  table:", S + 2, "scene.table",
     ["key 'table' has no value", "table: false"]),
    ("  table: {height: -0.01}", "  table: 0.5", S + 2, "scene.table",
     ["expected false, none or a mapping like {height: 0.0}, found 0.5"]),
    ("  table: {height: -0.01}", "  table: nothing", S + 2, "scene.table",
     ["found the string 'nothing'"]),
    ("  table: {height: -0.01}", "  table: {height: 750}", S + 2, "scene.table.height",
     ["table height 750 m is more than 10 m", "metres"]),
    ("  table: {height: -0.01}", "  table: {heigth: 0}", S + 2, "scene.table.heigth",
     ["unknown key 'heigth'", "did you mean 'height'?"]),
    ('rpy: [0, 0, "90 deg"]', 'rpy: [0, 0, "90 degrees"]', S + 4, "scene.base_in_world.rpy[2]",
     ["expected a number (radians) or a string like '90 deg'", "'90 degrees'"]),
    ("  base_in_world: {xyz: [0.4, 0.3, 0.75], rpy: [0, 0, \"90 deg\"]}",
     "  base_in_world: [0, 0, 0]", S + 4, "scene.base_in_world", ["expected a mapping"]),
    ("{name: ball,", "{name: wall,", S + 10, "scene.obstacles[1] (wall).name",
     ["duplicate obstacle name 'wall'", f"also at line {S + 6}, scene.obstacles[0] (wall)"]),
    ("{name: ball,", "{name: table,", S + 10, "scene.obstacles[1] (table).name",
     ["may not be called 'table'"]),
    ("{name: ball,", "{name: l2,", S + 10, "scene.obstacles[1] (l2).name",
     ["obstacle 'l2' has the name of a link of the arm"]),
    ("{name: ball, shape: sphere,", "{name: ball,", S + 10, "scene.obstacles[1] (ball)",
     ["missing required key 'shape'"]),
    ("{name: ball, shape: sphere,", "{shape: sphere,", S + 10, "scene.obstacles[1]",
     ["missing required key 'name'"]),
    ("shape: sphere, radius: 0.05, frame: world", "shape: ball, radius: 0.05", S + 10,
     "scene.obstacles[1] (ball).shape", ["'ball' is not one of: box, cylinder"]),
    ("frame: world", "frame: tool", S + 10, "scene.obstacles[1] (ball).frame",
     ["'tool' is not one of: base, world"]),
    ("frame: world", "colour: red", S + 10, "scene.obstacles[1] (ball).colour",
     ["unknown key 'colour'", "name, frame"]),
    ("size: [0.02, 0.4, 0.3]", "size: [0.02, -0.4, 0.3]", S + 8,
     "scene.obstacles[0] (wall).size", ["box sizes must be positive"]),
    ("radius: 0.05", "radius: 0", S + 10, "scene.obstacles[1] (ball).radius",
     ["must be greater than zero"]),
    ("meshes/rock.stl", "meshes/stone.stl", S + 13, "scene.obstacles[4] (rock).path",
     ["mesh file", "stone.stl' not found", "relative to the folder of this file"]),
    ("{links: [base, l1], reason: adjacent}", "{links: [base, l1x], reason: adjacent}",
     C + 4, "collision.allowed[0] (base / l1x).links[1]",
     ["unknown link 'l1x'", "did you mean 'l1'?", "the arm's links: base, l1, l2; and 'table'"]),
    ("{links: [base, l1], reason: adjacent}", "{links: [base, zz], reason: adjacent}",
     C + 4, "collision.allowed[0] (base / zz).links[1]",
     ["unknown link 'zz'\n  fix: the arm's links: base, l1, l2; and 'table'"]),
    ("{links: [base, l1], reason: adjacent}", "{links: [l1, l1], reason: adjacent}",
     C + 4, "collision.allowed[0] (l1 / l1).links", ["names 'l1' twice"]),
    ("{links: [base, l1], reason: adjacent}", "{links: [l2, l1], reason: adjacent}",
     C + 5, "collision.allowed[1] (l1 / l2)",
     ["the pair l1 / l2 is listed twice", f"also at line {C + 4}, collision.allowed[0]"]),
    ("{links: [base, l1], reason: adjacent}", "{links: [base, l1], reason: sometimes}",
     C + 4, "collision.allowed[0] (base / l1).reason",
     ["'sometimes' is not one of: " + ", ".join(r.value for r in AllowReason)]),
    ("{links: [base, l1], reason: adjacent}", "{links: [base, l1, l2], reason: adjacent}",
     C + 4, "collision.allowed[0] (base / l1 / l2).links",
     ["expected a list of two link names, found a list of 3 items"]),
    ("{links: [base, l1], reason: adjacent}", "{links: base, reason: adjacent}",
     C + 4, "collision.allowed[0].links", ["expected a list of two link names"]),
    ("{links: [base, l1], reason: adjacent}", "{links: [base, l1]}",
     C + 4, "collision.allowed[0] (base / l1)", ["missing required key 'reason'"]),
    ("{links: [base, l1], reason: adjacent}", "{links: [base, l1], reason: adjacent, why: x}",
     C + 4, "collision.allowed[0] (base / l1).why", ["unknown key 'why'", "links, reason, note"]),
    ("  samples: 1000", "  samples: -1", C + 2, "collision.samples", ["-1 is out of range"]),
    ("  samples: 1000", "  samples: 1.5", C + 2, "collision.samples",
     ["expected a whole number"]),
    ("  samples: 1000", "  sample: 1000", C + 2, "collision.sample",
     ["did you mean 'samples'?"]),
    ('note: "overlap in 100% of samples"', "note: 12", C + 5,
     "collision.allowed[1] (l1 / l2).note", ["expected a non-empty string"]),
])
def test_errors(tmp_path: Path, old: str, new: str, line: int, key: str,
                fragments: list[str]) -> None:
    text = ARM + SCENE + COLLISION
    assert text.count(old) == 1, old
    expect(tmp_path, text.replace(old, new), line, key, *fragments)


def test_obstacles_must_be_a_list(tmp_path: Path) -> None:
    expect(tmp_path, ARM + "scene:\n  obstacles: {}\n", S + 2, "scene.obstacles",
           "expected a list ('- ' items), found a mapping")


def test_a_link_called_table_is_refused_with_a_matrix(tmp_path: Path) -> None:
    text = ARM.replace("child: l2", "child: table") + "collision:\n  samples: 3\n"
    expect(tmp_path, text, ARM_LINES + 1, "collision", "the arm has a link called 'table'")
    assert load_arm_yaml(write(tmp_path, ARM.replace("child: l2", "child: table")))


def test_error_details_for_programs(tmp_path: Path) -> None:
    err = expect(tmp_path, ARM + "scene:\n  padding: 5\n", S + 2, "scene.padding")
    assert err.details["line"] == S + 2 and err.details["key"] == "scene.padding"
    assert err.details["fix"] and "0.005" in err.details["fix"]


@pytest.mark.parametrize(("text", "line", "key", "fragment"), [
    ("armctl: 2\ntable: false\n", 1, "armctl", "schema version 2 is newer"),
    ("table: false\ncollision: {}\n", 2, "collision", "unknown key 'collision'"),
    ("- {name: a, shape: sphere, radius: 1}\n", 1, "", "expected a mapping"),
    ("obstacles:\n  - {name: a, shape: sphere, radius: 1}\n  - {name: a, shape: sphere, "
     "radius: 2}\n", 3, "obstacles[1] (a).name", "duplicate obstacle name 'a' (also at line 2"),
])
def test_scene_file_errors(tmp_path: Path, text: str, line: int, key: str,
                           fragment: str) -> None:
    p = write(tmp_path, text, "scene.yaml")
    with pytest.raises(ConfigError) as info:
        load_scene(p)
    assert info.value.where.file == p and info.value.where.line == line
    assert (info.value.where.dotted() if key else "") == (key if key else "")
    assert fragment in str(info.value)


def test_missing_scene_file(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match="file not found"):
        load_scene(tmp_path / "nope.yaml")


# ---- writing -----------------------------------------------------------------------------------


def _reload(tmp_path: Path, text: str) -> armctl.config.ArmSpec:
    p = tmp_path / "out.yaml"
    p.write_text(text)
    return load_arm_yaml(p)


def test_round_trip_through_the_writer(tmp_path: Path) -> None:
    spec = load_arm_yaml(write(tmp_path, ARM + SCENE + COLLISION))
    text = dump_arm_yaml(spec, tmp_path / "out.yaml")
    assert "path: meshes/rock.stl" in text  # relative to the written file
    back = _reload(tmp_path, text)
    assert back.scene == spec.scene and back.collision == spec.collision
    assert back.scene is not None and back.scene.obstacles  # not two empty sections
    assert dump_arm_yaml(back, tmp_path / "out.yaml") == text


@pytest.mark.parametrize("note", ["a: b, c # d", "two\nlines\n", "tab\there", "'quoted' \"too\"",
                                  "1e5", "true", "ünïcödé ✓", "-", "[x]", "\x7f\U0001f600"])
def test_awkward_notes_and_names_round_trip(tmp_path: Path, note: str) -> None:
    spec = load_arm_yaml(write(tmp_path, ARM))
    scene = SceneSpec(table=None, padding=0.0, obstacles=(
        Obstacle("a: b", Sphere(0.1, Origin((1e-9, 0.0, -2.5)))),
        Obstacle("1e5", Box((1.0, 2.0, 3.0)), SceneFrame.WORLD)))
    col = CollisionSpec((AllowedPair("l1", TABLE, AllowReason.NEVER, note),), 7)
    from dataclasses import replace

    spec = replace(spec, scene=scene, collision=col)
    back = _reload(tmp_path, dump_arm_yaml(spec))
    assert back.scene == scene and back.collision == col


def test_scene_file_round_trip(tmp_path: Path) -> None:
    spec = load_arm_yaml(write(tmp_path, ARM + SCENE))
    assert spec.scene is not None
    out = tmp_path / "scene.yaml"
    out.write_text(dump_scene_yaml(spec.scene, out, header="a scene"))
    assert out.read_text().startswith("# a scene\narmctl: 1\n")
    back = load_scene(out)
    assert back.obstacles == spec.scene.obstacles and back.table == spec.scene.table
    assert back.padding == spec.scene.padding
    assert back.base_in_world == spec.scene.base_in_world


FIXED = ARM.replace("""links:""", """  - name: mount
    type: fixed
    parent: l2
    child: cam
    origin: {xyz: [0.05, 0, 0]}
links:""")


@pytest.mark.parametrize(("pairs", "kept"), [
    # every pair merged into (l1, l2) allowed: kept, renamed
    ([("l1", "l2"), ("l1", "cam")], [("l1", "l2")]),
    # (l1, cam) was checked: after the merge, (l1, l2) must be checked too
    ([("l1", "l2")], []),
    ([("l1", "cam")], []),
    # a pair inside the merged link disappears
    ([("l2", "cam"), ("base", "l1")], [("base", "l1")]),
    ([("cam", TABLE), ("l2", TABLE)], [("l2", TABLE)]),
])
def test_merging_fixed_joints_keeps_only_safe_pairs(
        tmp_path: Path, pairs: list[tuple[str, str]], kept: list[tuple[str, str]]) -> None:
    rows = "".join(f"    - {{links: [{a}, {b}], reason: user}}\n" for a, b in pairs)
    spec = load_arm_yaml(write(tmp_path, FIXED + "collision:\n  allowed:\n" + rows))
    merged = merge_fixed(spec)
    assert merged.collision is not None
    assert [(p.a, p.b) for p in merged.collision.allowed] == kept
    back = _reload(tmp_path, dump_arm_yaml(spec))  # loads: no pair names the merged link
    assert back.collision == merged.collision


# ---- replacing the collision section in place ------------------------------------------------

NEW = CollisionSpec((
    AllowedPair("base", "l1", AllowReason.ADJACENT),
    AllowedPair("l2", TABLE, AllowReason.NEVER, "no contact in 500 samples"),
), 500)
#: NEW as it must be written (spelled out here, not produced by the writer under test).
NEW_TEXT = """\
collision:
  samples: 500
  allowed:
    - {links: [base, l1], reason: adjacent}
    - {links: [l2, table], reason: never, note: no contact in 500 samples}
"""

AFTER = """\

# poses a user wrote   (kept)
poses:
  home: [0, 0]   # home
"""


@pytest.mark.parametrize("old", [
    COLLISION,
    "collision:\n",  # a key without value
    "collision: {samples: 3, allowed: []}   # flow style\n",
    "collision:  # the matrix\n  # a comment inside\n  samples: 2\n  allowed:\n"
    "    - links: [l1, l2]\n      reason: user\n      note: |\n        two\n        lines\n\n",
])
def test_replace_keeps_everything_else(tmp_path: Path, old: str) -> None:
    before = ARM + "# the scene\n" + SCENE
    p = write(tmp_path, before + old + AFTER)
    mode = 0o640
    p.chmod(mode)
    replace_collision_section(p, NEW)
    text = p.read_text()
    blank = old[len(old.rstrip("\n")) + 1:]  # blank lines after the old value stay
    assert text == before + NEW_TEXT + blank + AFTER
    assert (p.stat().st_mode & 0o777) == mode
    spec = load_arm_yaml(p)
    assert spec.collision == NEW
    assert spec.links[1].collision  # the links' own 'collision:' shapes are untouched
    assert spec.poses == {"home": {"j1": 0.0, "j2": 0.0}}


def test_replace_at_the_end_and_appending(tmp_path: Path) -> None:
    p = write(tmp_path, ARM + COLLISION.rstrip("\n"))  # last section, no final line end
    replace_collision_section(p, NEW)
    assert p.read_text() == ARM + NEW_TEXT
    p.write_text(ARM + "poses: {home: [0, 0]}  # no line end")
    replace_collision_section(p, NEW)
    assert p.read_text() == ARM + "poses: {home: [0, 0]}  # no line end\n" + NEW_TEXT
    p.write_text(ARM)
    replace_collision_section(p, CollisionSpec())
    assert p.read_text() == ARM + "collision:\n  samples: 0\n  allowed: []\n"
    assert load_arm_yaml(p).collision == CollisionSpec()


def test_replace_keeps_windows_line_ends(tmp_path: Path) -> None:
    before = (ARM + SCENE).replace("\n", "\r\n")
    after = AFTER.replace("\n", "\r\n")
    p = tmp_path / "arm.yaml"
    (tmp_path / "meshes").mkdir()
    (tmp_path / "meshes" / "rock.stl").write_text("solid\n")
    p.write_bytes((before + COLLISION.replace("\n", "\r\n") + after).encode())
    replace_collision_section(p, NEW)
    assert p.read_bytes() == (before + NEW_TEXT.replace("\n", "\r\n") + after).encode()


@pytest.mark.parametrize(("text", "spec", "fragment"), [
    (ARM + COLLISION, CollisionSpec((AllowedPair("base", "l7", AllowReason.USER),)),
     "unknown link 'l7'"),
    (ARM + COLLISION, CollisionSpec((AllowedPair("l1", "l1", AllowReason.USER),)),
     "names 'l1' twice"),
    (ARM + COLLISION, CollisionSpec((AllowedPair("l1", "l2", AllowReason.USER),
                                     AllowedPair("l2", "l1", AllowReason.NEVER))),
     "listed twice"),
    (ARM.replace("name: t", "nme: t") + COLLISION, NEW, "unknown key 'nme'"),  # a broken file
    ("{" + ", ".join(f"{k}: {v}" for k, v in (("name", "t"), ("base", "b"), (
        "joints", "[{name: j, type: continuous, parent: b, child: c}]"))) + "}\n",
     CollisionSpec((AllowedPair("b", "c", AllowReason.ADJACENT),)), "flow style"),
    # an alias after the section refers to an anchor inside it: refused, not broken
    (ARM + COLLISION.replace('"overlap in 100% of samples"', '&why "overlap"')
     + "description: *why\n", NEW, "alias *why has no anchor"),
])
def test_replace_refuses_and_leaves_the_file(tmp_path: Path, text: str, spec: CollisionSpec,
                                             fragment: str) -> None:
    p = write(tmp_path, text)
    before = p.read_bytes()
    with pytest.raises(ConfigError) as info:
        replace_collision_section(p, spec)
    assert fragment in str(info.value)
    assert str(p) in str(info.value)
    assert p.read_bytes() == before
    assert sorted(x.name for x in tmp_path.iterdir()) == ["arm.yaml", "meshes"]  # no temp file


@pytest.mark.parametrize("name", BUNDLED)
def test_rewriting_a_bundled_matrix_changes_nothing(name: str) -> None:
    path = CONFIGS / f"{name}.yaml"
    text = path.read_text()
    spec = load_arm_yaml(path)
    assert spec.collision is not None, "every bundled arm ships its allowed-collision matrix"
    assert with_collision_section(text, spec.collision, path) == text
    fewer = CollisionSpec(spec.collision.allowed[1:], spec.collision.samples)
    out = with_collision_section(text, fewer, path)
    start = text.index("\ncollision:")
    assert out[:start] == text[:start]  # everything before the section is kept as it is
    assert parse_arm(parse_yaml(out, path)).collision == fewer


def test_replace_does_not_touch_nested_collision_keys() -> None:
    text = ARM + "poses:\n  collision: [0, 0]\n"  # a pose called 'collision'
    out = with_collision_section(text, NEW)
    assert out == text + NEW_TEXT
    assert parse_arm(parse_yaml(out)).poses["collision"] == {"j1": 0.0, "j2": 0.0}


# ---- the examples in docs/config.md ------------------------------------------------------------

DOCS = REPO / "docs" / "config.md"
DOC_ARM = """\
name: doc
base: base_link
joints:
  - {name: shoulder, type: revolute, parent: base_link, child: upper_arm,
     limits: {lower: -2.5, upper: 2.5}}
  - {name: gripper, type: prismatic, parent: upper_arm, child: jaw, axis: [1, 0, 0],
     limits: {lower: 0.0, upper: 0.04}}
"""


def _blocks(heading: str) -> list[str]:
    text = DOCS.read_text()
    section = text.split(f"\n## {heading}\n", 1)[1].split("\n## ", 1)[0]
    return re.findall(r"```(?:yaml)?\n(.*?)```", section, re.S)


def test_docs_scene_examples(tmp_path: Path) -> None:
    section, scene_file, error = _blocks("Scene")
    (tmp_path / "meshes").mkdir()
    (tmp_path / "meshes" / "fixture.stl").write_text("solid\n")
    spec = load_arm_yaml(write(tmp_path, DOC_ARM + section))
    assert spec.scene is not None
    assert [o.name for o in spec.scene.obstacles] == ["wall", "cup", "lamp", "post", "fixture"]
    assert load_scene(write(tmp_path, scene_file, "scene.yaml")).table is None
    # the documented error message is the one armctl gives
    lines = scene_file.splitlines()
    p = write(tmp_path, "\n".join([*lines, lines[-1]]) + "\n", "scene.yaml")
    with pytest.raises(ConfigError) as info:
        load_scene(p)
    assert str(info.value) == error.strip().replace("scene.yaml", str(p))


def test_docs_collision_examples(tmp_path: Path) -> None:
    section, error = _blocks("Collision matrix")
    spec = load_arm_yaml(write(tmp_path, DOC_ARM + section))
    assert spec.collision is not None and len(spec.collision.allowed) == 6
    assert {p.reason for p in spec.collision.allowed} == set(AllowReason)
    bad = (DOC_ARM + section).replace("[upper_arm, jaw]", "[upper_arm, jwa]")
    p = write(tmp_path, bad)
    with pytest.raises(ConfigError) as info:
        load_arm_yaml(p)
    line = bad.splitlines().index(next(x for x in bad.splitlines() if "jwa" in x)) + 1
    assert str(info.value) == re.sub(r"arm\.yaml:\d+", f"{p}:{line}", error.strip())
