"""Hostile and absurd config files: each is a ConfigError naming file, line and key, fast and small.

Empty values, YAML tags, huge numbers, deep nesting, alias bombs, infinite values after unit
conversion, overflowing axes, non-finite URDF limits, and arms too big to model. The big and
malicious files are generated here; memory is measured with tracemalloc or, where a whole
process matters, with the peak resident size of a subprocess.
"""

from __future__ import annotations

import importlib
import json
import subprocess
import sys
import time
import tracemalloc
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml

import armctl
from armctl.cli import main
from armctl.config import source
from armctl.config.arm_yaml import load_arm_yaml
from armctl.config.schema import ArmSpec, JointSpec, JointType, Limits
from armctl.config.source import (
    MAX_ALIAS_VALUES,
    MAX_ALIASES,
    MAX_DEPTH,
    MAX_FILE_BYTES,
    MAX_NUMBER_CHARS,
    MAX_VALUES,
    load_yaml,
    parse_yaml,
)
from armctl.config.tree import MAX_JOINTS
from armctl.config.urdf import load_urdf
from armctl.config.writer import dump_arm_yaml
from armctl.errors import ConfigError
from armctl.kinematics.model import KinematicModel
from armctl.motion.keyframe_file import parse_keyframes

# the module (the package exports a function of the same name)
classify = importlib.import_module("armctl.ik.analytic.classify")

GOOD = """\
armctl: 1
name: t
description: a test arm
base: base
joints:
  - name: j1
    type: revolute
    parent: base
    child: l1
    axis: [0, 0, 1]
    limits: {lower: -1, upper: 1, velocity: 2}
  - name: j2
    type: revolute
    parent: l1
    child: l2
    origin: {xyz: [0.1, 0, 0]}
    axis: [0, 1, 0]
    limits: {lower: -1, upper: 1}
"""

#: Nine levels of nine aliases: 9^9 (387 million) strings when expanded, in a few hundred bytes.
ALIAS_BOMB = "".join(
    [f'a: &a [{",".join(9 * ["lol"])}]\n']
    + [f"{b}: &{b} [{','.join(9 * ['*' + a])}]\n"
       for a, b in zip("abcdefgh", "bcdefghi", strict=True)]
)


@pytest.fixture(params=["libyaml", "python"])
def loader(request: pytest.FixtureRequest, monkeypatch: pytest.MonkeyPatch) -> str:
    """Run a test with the C event parser and with PyYAML's pure-Python one."""
    if request.param == "python":
        monkeypatch.setattr(source, "_LOADER", yaml.SafeLoader)
    elif not hasattr(yaml, "CSafeLoader"):
        pytest.fail("PyYAML was built without libyaml; armctl's requirements include it")
    return str(request.param)


def write(tmp_path: Path, text: str, name: str = "arm.yaml") -> Path:
    p = tmp_path / name
    p.write_text(text, encoding="utf-8")
    return p


def refused(path: Path, *fragments: str, line: int | None = None,
            key: str | None = None) -> ConfigError:
    """Load ``path`` as an arm, expect a ConfigError naming the file, line and key path."""
    with pytest.raises(ConfigError) as info:
        armctl.load_arm(path)
    err = info.value
    msg = str(err)
    assert path.name in msg, msg
    assert "np.float64" not in msg, msg
    for frag in fragments:
        assert frag in msg, (frag, msg)
    if line is not None:
        assert err.where.line == line, (err.where, msg)
        assert f"{path.name}:{line}:" in msg, msg
    if key is not None:
        assert err.where.dotted() == key, (err.where.dotted(), msg)
    assert err.fix, msg
    return err


def chain_yaml(n: int, axes: tuple[str, ...] = ("[0, 0, 1]",), xyz: str = "[0.01, 0, 0]") -> str:
    """An ``n``-joint serial chain; the axes cycle through ``axes``."""
    out = ["name: big", "base: l0", "joints:"]
    for i in range(n):
        out += [f"  - name: j{i}", "    type: revolute", f"    parent: l{i}",
                f"    child: l{i + 1}", f"    origin: {{xyz: {xyz}}}",
                f"    axis: {axes[i % len(axes)]}", "    limits: {lower: -1, upper: 1}"]
    return "\n".join(out) + "\n"


# ---- empty values ---------------------------------------------------------------------------
def test_empty_optional_value_is_absent(tmp_path: Path, loader: str) -> None:
    arm = armctl.load_arm(write(tmp_path, GOOD.replace("description: a test arm", "description:")))
    assert arm.spec.description == ""


def test_empty_required_value_says_it_has_no_value(tmp_path: Path, loader: str) -> None:
    err = refused(write(tmp_path, GOOD.replace("name: t\n", "name:\n")),
                  "key 'name' has no value", line=2, key="name")
    assert err.fix == "write a value after 'name:'"
    refused(write(tmp_path, GOOD.replace("    type: revolute\n    parent: l1", "    type:\n"
                                         "    parent: l1")),
            "key 'type' has no value", line=13, key="joints[1] (j2).type")


# ---- tags -----------------------------------------------------------------------------------
@pytest.mark.parametrize("tagged, shown", [
    ("!foo j1", "!foo"),
    ("!!python/object/apply:os.system ['true']", "!!python/object/apply:os.system"),
    ("!!binary aGVsbG8=", "!!binary"),
])
def test_yaml_tags_are_refused(tmp_path: Path, loader: str, tagged: str, shown: str) -> None:
    text = GOOD.replace("  - name: j1\n", f"  - name: {tagged}\n")
    refused(write(tmp_path, text), f"YAML tags like {shown} are not supported", line=6,
            key="joints[0].name")


def test_tags_on_lists_and_mappings_are_refused(tmp_path: Path, loader: str) -> None:
    text = GOOD.replace("limits: {lower: -1, upper: 1, velocity: 2}",
                        "limits: !!omap {lower: -1, upper: 1}")
    refused(write(tmp_path, text), "YAML tags like !!omap are not supported", line=11,
            key="joints[0] (j1).limits")
    refused(write(tmp_path, GOOD.replace("axis: [0, 1, 0]", "axis: !vec [0, 1, 0]")),
            "YAML tags like !vec", line=17)


def test_core_type_tags_are_plain_values(tmp_path: Path, loader: str) -> None:
    text = GOOD.replace("velocity: 2}", "velocity: !!float 2}").replace("name: t", "name: !!str 7")
    arm = armctl.load_arm(write(tmp_path, text))
    assert arm.name == "7"
    assert arm.velocity_limits[0] == 2.0
    refused(write(tmp_path, text.replace("!!float 2", "!!int two")), "'two' is not a valid !!int",
            line=11)


# ---- numbers --------------------------------------------------------------------------------
def test_400_digit_integer(tmp_path: Path, loader: str) -> None:
    text = GOOD.replace("upper: 1, velocity", f"upper: {'9' * 400}, velocity")
    refused(write(tmp_path, text), "has 400 characters",
            f"armctl reads numbers of up to {MAX_NUMBER_CHARS}", line=11,
            key="joints[0] (j1).limits.upper")


@pytest.mark.parametrize("value, found", [
    ("'1e400 deg'", "'1e400 deg'"),
    ("'-1e400 rad'", "'-1e400 rad'"),
    ("1e309", "inf"),
    ("1.0e+400", "inf"),
    (".inf", "inf"),
    (".nan", "nan"),
])
def test_infinite_after_conversion(tmp_path: Path, loader: str, value: str, found: str) -> None:
    text = GOOD.replace("lower: -1, upper: 1, velocity", f"lower: -1, upper: {value}, velocity")
    refused(write(tmp_path, text), "expected a finite number", found, line=11,
            key="joints[0] (j1).limits.upper")


def test_infinite_velocity_and_pose(tmp_path: Path, loader: str) -> None:
    refused(write(tmp_path, GOOD.replace("velocity: 2", "velocity: .inf")),
            "expected a finite number", key="joints[0] (j1).limits.velocity")
    refused(write(tmp_path, GOOD + "poses:\n  home: ['1e999 deg', 0]\n"),
            "expected a finite number", line=20, key="poses.home[0]")


def test_exponent_without_a_dot_is_a_number(tmp_path: Path, loader: str) -> None:
    arm = armctl.load_arm(write(tmp_path, GOOD.replace("velocity: 2", "velocity: 2e-1")))
    assert arm.velocity_limits[0] == pytest.approx(0.2)


# ---- axes -----------------------------------------------------------------------------------
def test_huge_axis_is_normalised_not_zero(tmp_path: Path, loader: str) -> None:
    arm = armctl.load_arm(write(tmp_path, GOOD.replace("axis: [0, 1, 0]",
                                                       "axis: [1e308, 1e308, 0]")))
    axis = arm.spec.joint("j2").axis
    assert axis == pytest.approx((2 ** -0.5, 2 ** -0.5, 0.0))
    assert np.all(np.isfinite(arm.fk([0.3, 0.4])))


def test_zero_axis_message_prints_plain_numbers(tmp_path: Path, loader: str) -> None:
    err = refused(write(tmp_path, GOOD.replace("axis: [0, 1, 0]", "axis: [0.0, 0, 0]")),
                  "axis [0, 0, 0] has zero length", line=17, key="joints[1] (j2).axis")
    assert "np." not in str(err)


# ---- nesting, aliases, size ---------------------------------------------------------------
@pytest.mark.parametrize("style", ["flow", "block"])
def test_2000_levels_of_nesting(tmp_path: Path, loader: str, style: str) -> None:
    if style == "flow":
        deep = "x: " + "[" * 2000 + "]" * 2000 + "\n"
    else:
        deep = "x:\n" + "".join("  " * (i + 1) + f"k{i}:\n" for i in range(2000))
    path = write(tmp_path, GOOD + deep)
    start = time.perf_counter()
    refused(path, f"nested more than {MAX_DEPTH} levels deep")
    assert time.perf_counter() - start < 10.0  # was a RecursionError; now stops at MAX_DEPTH


def test_nesting_just_below_the_limit_is_read(loader: str) -> None:
    doc = parse_yaml("x: " + "[" * (MAX_DEPTH - 1) + "]" * (MAX_DEPTH - 1) + "\n")
    value, depth = doc.data["x"], 1
    while value:
        value, depth = value[0], depth + 1
    assert depth == MAX_DEPTH - 1


def test_alias_bomb_is_refused_fast_and_small(tmp_path: Path, loader: str) -> None:
    assert len(ALIAS_BOMB.encode()) < 400
    path = write(tmp_path, ALIAS_BOMB)
    tracemalloc.start()
    start = time.perf_counter()
    try:
        with pytest.raises(ConfigError) as info:
            load_yaml(path)
        seconds = time.perf_counter() - start
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    msg = str(info.value)
    assert "too many aliases" in msg and "arm.yaml:" in msg, msg
    assert info.value.where.line is not None and info.value.where.keys
    assert seconds < 10.0, seconds  # 60 s and more before
    assert peak < 64 * 2**20, peak  # 1.8 GB before


def test_too_many_aliases(loader: str) -> None:
    text = "a: &a 1\nb: [" + ", ".join(["*a"] * (MAX_ALIASES + 1)) + "]\n"
    with pytest.raises(ConfigError, match=f"more than {MAX_ALIASES} aliases"):
        parse_yaml(text)
    ok = "a: &a 1\nb: [" + ", ".join(["*a"] * MAX_ALIASES) + "]\n"
    assert len(parse_yaml(ok).data["b"]) == MAX_ALIASES
    big = "a: &a [" + ", ".join(["0"] * 1000) + "]\nb: [" + ", ".join(["*a"] * 200) + "]\n"
    with pytest.raises(ConfigError, match=f"more than {MAX_ALIAS_VALUES} values copied"):
        parse_yaml(big)


def test_aliases_nesting_counts_expanded(loader: str) -> None:
    half = MAX_DEPTH // 2 + 1
    text = "a: &a " + "[" * half + "]" * half + "\nb: " + "[" * half + "*a" + "]" * half + "\n"
    with pytest.raises(ConfigError, match="alias \\*a nests lists and mappings more than"):
        parse_yaml(text)


def test_alias_errors(loader: str) -> None:
    with pytest.raises(ConfigError, match=r"alias \*a is inside the value &a"):
        parse_yaml("a: &a [1, *a]\n")
    with pytest.raises(ConfigError, match=r"alias \*nope has no anchor &nope"):
        parse_yaml("a: *nope\n")


def test_anchors_aliases_and_merge_keys_work(tmp_path: Path, loader: str) -> None:
    text = GOOD.replace("limits: {lower: -1, upper: 1, velocity: 2}",
                        "limits: &lim {lower: -1, upper: 1, velocity: 2}")
    text = text.replace("limits: {lower: -1, upper: 1}", "limits: {<<: *lim, upper: 0.5}")
    arm = armctl.load_arm(write(tmp_path, text))
    assert arm.upper.tolist() == [1.0, 0.5]
    assert arm.velocity_limits.tolist() == [2.0, 2.0]
    refused(write(tmp_path, text.replace("{<<: *lim, upper: 0.5}", "{<<: 3, upper: 0.5}")),
            "'<<' merges mappings", line=18)


def test_too_many_values() -> None:
    with pytest.raises(ConfigError, match=f"more than {MAX_VALUES} values"):
        parse_yaml("x: [" + "0," * MAX_VALUES + "0]\n")


def test_file_size_is_bounded(tmp_path: Path) -> None:
    path = tmp_path / "huge.yaml"
    with path.open("w") as f:
        f.write(GOOD)
        f.write(("# " + "x" * 1000 + "\n") * (MAX_FILE_BYTES // 1000))
    with pytest.raises(ConfigError, match="larger than 8 MiB") as info:
        armctl.load_arm(path)
    assert "huge.yaml" in str(info.value)
    if Path("/dev/zero").exists():  # no size to ask for: the read itself is bounded
        with pytest.raises(ConfigError, match="larger than"):
            load_yaml("/dev/zero")


def test_more_than_one_document(loader: str) -> None:
    with pytest.raises(ConfigError, match="more than one YAML document") as info:
        parse_yaml("a: 1\n---\nb: 2\n")
    assert info.value.where.line == 2


def test_keyframe_files_are_protected_too(tmp_path: Path) -> None:
    arm = armctl.load_arm("so101")
    path = write(tmp_path, ALIAS_BOMB, "moves.yaml")
    with pytest.raises(ConfigError, match="too many aliases"):
        parse_keyframes(path.read_text(), arm, path)
    text = "armctl_keyframes: 1\narm: so101\njoints: !joints [a]\nkeyframes: []\n"
    with pytest.raises(ConfigError, match="YAML tags like !joints") as info:
        parse_keyframes(text, arm, path)
    assert info.value.where.line == 3


# ---- URDF ---------------------------------------------------------------------------------
URDF = """\
<?xml version="1.0"?>
<robot name="r">
  <link name="base"/>
  <link name="l1"/>
  <joint name="j1" type="revolute">
    <parent link="base"/>
    <child link="l1"/>
    <axis xyz="AXIS"/>
    <limit lower="LOWER" upper="UPPER" velocity="VELOCITY" effort="EFFORT"/>
  </joint>
</robot>
"""


def urdf(tmp_path: Path, **values: str) -> Path:
    text = URDF
    for key, default in (("AXIS", "0 0 1"), ("LOWER", "-1"), ("UPPER", "1"), ("VELOCITY", "2"),
                         ("EFFORT", "3")):
        text = text.replace(key, values.get(key.lower(), default))
    return write(tmp_path, text, "arm.urdf")


@pytest.mark.parametrize("attr", ["lower", "upper", "velocity", "effort"])
@pytest.mark.parametrize("value", ["nan", "inf", "-inf", "1e400"])
def test_urdf_non_finite_limits(tmp_path: Path, attr: str, value: str) -> None:
    path = urdf(tmp_path, **{attr: value})
    with pytest.raises(ConfigError) as info:
        load_urdf(path)
    err = info.value
    msg = str(err)
    assert f"arm.urdf:9: joint[0] (j1).limit.{attr}:" in msg, msg
    assert f"attribute {attr}='{value}' of <limit> must be a finite number" in msg
    assert err.fix


def test_urdf_huge_axis_and_zero_axis(tmp_path: Path) -> None:
    spec = load_urdf(urdf(tmp_path, axis="1e308 -1e308 0")).spec
    assert spec.joint("j1").axis == pytest.approx((2 ** -0.5, -(2 ** -0.5), 0.0))
    with pytest.raises(ConfigError, match=r"zero-length axis \(0 0 0\)") as info:
        load_urdf(urdf(tmp_path, axis="0 0 0"))
    assert info.value.where.line == 8


def test_urdf_entity_bomb(tmp_path: Path) -> None:
    entities = '<!ENTITY e0 "lol">' + "".join(
        f'<!ENTITY e{i} "{("&e" + str(i - 1) + ";") * 10}">' for i in range(1, 10))
    text = f'<?xml version="1.0"?><!DOCTYPE r [{entities}]><robot name="&e9;"/>'
    start = time.perf_counter()
    with pytest.raises(ConfigError, match="not well-formed XML"):
        load_urdf(write(tmp_path, text, "bomb.urdf"))
    assert time.perf_counter() - start < 10.0


def test_converted_names_read_back(tmp_path: Path) -> None:
    """Names that YAML would read as numbers, booleans or syntax are quoted when written."""
    text = URDF.replace('name="j1"', 'name="1e5"').replace('"l1"', '"yes"')
    text = text.replace('name="base"', 'name="a: b"').replace('link="base"', 'link="a: b"')
    for key, value in (("AXIS", "0 0 1"), ("LOWER", "-1"), ("UPPER", "1"), ("VELOCITY", "2"),
                       ("EFFORT", "3")):
        text = text.replace(key, value)
    spec = load_urdf(write(tmp_path, text, "odd.urdf")).spec
    out = tmp_path / "odd.yaml"
    out.write_text(dump_arm_yaml(spec, out), encoding="utf-8")
    back = load_arm_yaml(out)
    assert [j.name for j in back.joints] == ["1e5"]
    assert back.base == "a: b" and back.tool == "yes"


# ---- big arms -----------------------------------------------------------------------------
_PROBE = """
import json, resource, sys, time
import numpy as np
import armctl
from armctl.errors import ConfigError
before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
start = time.perf_counter()
out = {}
try:
    arm = armctl.load_arm(sys.argv[1])
    q = np.zeros(arm.dof)
    out["dof"] = arm.dof
    out["finite"] = bool(np.isfinite(arm.fk(q)).all() and np.isfinite(arm.jacobian(q)).all())
    out["frames"] = len(arm.fk_all(q))
except ConfigError as exc:
    out["error"] = str(exc)
out["seconds"] = time.perf_counter() - start
out["mib"] = (resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - before) / 1024
print(json.dumps(out))
"""


def probe(path: Path) -> dict[str, Any]:
    """Load an arm in a fresh process: its result, time and growth of peak memory [MiB]."""
    run = subprocess.run([sys.executable, "-c", _PROBE, str(path)], capture_output=True,
                         text=True, timeout=600)
    assert run.returncode == 0, run.stderr
    result: dict[str, Any] = json.loads(run.stdout)
    return result


def test_10000_joint_yaml_is_refused_with_bounded_memory(tmp_path: Path) -> None:
    result = probe(write(tmp_path, chain_yaml(10_000)))
    assert "arm.yaml:3: joints: the arm has 10000 joints" in str(result["error"])
    assert f"up to {MAX_JOINTS} joints" in str(result["error"])
    assert float(result["mib"]) < 400, result  # 15 GB before


def test_largest_arm_loads_with_bounded_memory(tmp_path: Path) -> None:
    result = probe(write(tmp_path, chain_yaml(MAX_JOINTS)))
    assert result.get("dof") == MAX_JOINTS and result["finite"], result
    assert result["frames"] == MAX_JOINTS + 1
    assert float(result["mib"]) < 600, result
    refused(write(tmp_path, chain_yaml(MAX_JOINTS + 1)), f"up to {MAX_JOINTS} joints", line=3,
            key="joints")


def test_arm_size_is_checked_for_specs_built_in_memory() -> None:
    joints = tuple(JointSpec(f"j{i}", JointType.REVOLUTE, f"l{i}", f"l{i + 1}",
                             limits=Limits(-1.0, 1.0)) for i in range(MAX_JOINTS + 1))
    spec = ArmSpec("big", "l0", (), joints, tool=f"l{MAX_JOINTS + 1}")
    with pytest.raises(ConfigError, match=f"up to {MAX_JOINTS} joints"):
        KinematicModel(spec)


@pytest.mark.parametrize("axes, xyz", [
    (("[0, 0, 1]",), "[0.01, 0, 0]"),  # all parallel: a planar chain
    (("[1, 0, 0]", "[0, 1, 0]", "[0, 0, 1]"), "[0, 0, 0]"),  # every three axes meet
])
def test_classification_of_a_200_joint_chain_is_bounded(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch, axes: tuple[str, ...], xyz: str) -> None:
    arm = armctl.load_arm(write(tmp_path, chain_yaml(200, axes, xyz)))
    calls = 0
    real = classify._common_point

    def counted(*args: object, **kwargs: object) -> object:
        nonlocal calls
        calls += 1
        return real(*args, **kwargs)

    monkeypatch.setattr(classify, "_common_point", counted)
    start = time.perf_counter()
    assert classify.describe(arm) == "none (use a numerical solver)"
    assert calls <= classify.MAX_TRIPLES  # 1.3 million triples (57 s) before
    assert time.perf_counter() - start < 20.0


def test_long_chain_with_a_closed_form_keeps_it(tmp_path: Path) -> None:
    arm = armctl.load_arm(write(tmp_path, chain_yaml(200, ("[1, 0, 0]", "[0, 1, 0]",
                                                           "[0, 0, 1]"))))
    dec = classify.classify(arm, kind=classify.GoalKind.POSITION)
    assert dec.family is classify.Family.POSITION_3R and len(dec.free) == 197
    assert "(197 joints)" in dec.describe(arm) and "j199" in dec.describe(arm)


def test_cli_info_on_a_200_joint_chain(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = write(tmp_path, chain_yaml(200, ("[1, 0, 0]", "[0, 1, 0]", "[0, 0, 1]"), "[0, 0, 0]"))
    start = time.perf_counter()
    assert main(["info", str(path)]) == 0
    assert time.perf_counter() - start < 30.0  # 57 s before (a few tenths of a second now)
    out = capsys.readouterr().out
    assert "200 DOF" in out and "j199 (revolute) -> l200" in out


# ---- the command line ----------------------------------------------------------------------
CLI_CASES = {
    "empty": (GOOD.replace("name: t\n", "name:\n"), "key 'name' has no value"),
    "tag": (GOOD.replace("name: j1", "name: !foo j1"), "YAML tags like !foo"),
    "bigint": (GOOD.replace("upper: 1,", f"upper: {'7' * 400},"), "has 400 characters"),
    "nesting": (GOOD + "x: " + "[" * 2000 + "]" * 2000 + "\n", "nested more than"),
    "bomb": (ALIAS_BOMB, "too many aliases"),
    "deg": (GOOD.replace("upper: 1,", "upper: '1e400 deg',"), "expected a finite number"),
    "joints": (chain_yaml(MAX_JOINTS + 5), f"up to {MAX_JOINTS} joints"),
}


@pytest.mark.parametrize("case", sorted(CLI_CASES))
def test_cli_info_exit_code(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                            case: str) -> None:
    text, fragment = CLI_CASES[case]
    path = write(tmp_path, text, f"{case}.yaml")
    assert main(["info", str(path)]) == 2
    err = capsys.readouterr().err
    assert f"{case}.yaml:" in err and fragment in err, err
    assert "Traceback" not in err and "fix:" in err


@pytest.mark.parametrize("case", ["nesting", "bomb"])
def test_cli_process_exit_code(tmp_path: Path, case: str) -> None:
    text, fragment = CLI_CASES[case]
    path = write(tmp_path, text, f"{case}.yaml")
    run = subprocess.run([sys.executable, "-m", "armctl", "info", str(path)],
                         capture_output=True, text=True, timeout=300)
    assert run.returncode == 2, run.stderr
    assert fragment in run.stderr and "Traceback" not in run.stderr
    urdf_path = urdf(tmp_path, velocity="nan")
    run = subprocess.run([sys.executable, "-m", "armctl", "info", str(urdf_path)],
                         capture_output=True, text=True, timeout=300)
    assert run.returncode == 2 and "must be a finite number" in run.stderr, run.stderr
    assert "Traceback" not in run.stderr


def test_big_urdf_is_refused_unless_a_tip_keeps_a_short_chain(tmp_path: Path) -> None:
    n = MAX_JOINTS + 500
    parts = ['<?xml version="1.0"?>', '<robot name="long">']
    parts += [f'  <link name="l{i}"/>' for i in range(n + 1)]
    for i in range(n):
        parts += [f'  <joint name="j{i}" type="revolute">', f'    <parent link="l{i}"/>',
                  f'    <child link="l{i + 1}"/>', '    <origin xyz="0.01 0 0"/>',
                  '    <axis xyz="0 0 1"/>', '    <limit lower="-1" upper="1"/>', "  </joint>"]
    path = write(tmp_path, "\n".join([*parts, "</robot>"]) + "\n", "long.urdf")
    start = time.perf_counter()
    with pytest.raises(ConfigError, match=f"the arm has {n} joints; armctl supports arms of up to"):
        load_urdf(path)
    assert load_urdf(path, tip="l5").spec.tool == "l5"
    assert len(armctl.load_arm(path, tip="l5").joint_names) == 5
    assert time.perf_counter() - start < 60.0  # the tree checks are linear in the joints
