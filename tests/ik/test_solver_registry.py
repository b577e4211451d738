"""The solver registry's capabilities, and the goal kinds: one numbering, one registry."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from armctl.arm import load_arm
from armctl.cli import main
from armctl.errors import InputError, UnknownNameError
from armctl.ik import (
    Capabilities,
    Goal,
    GoalKind,
    IKOptions,
    OrientationGoal,
    PoseGoal,
    PositionGoal,
    goal_class,
    goal_classes,
    solve_batch,
    solver_info,
    solver_infos,
)
from armctl.ik.errors import UnsupportedGoalError
from armctl.ik.nlp import OnPlane
from armctl.ik.registry import check_request, solver_for


def test_capabilities_are_frozen_data() -> None:
    infos = solver_infos()
    assert [i.name for i in infos][:2] == ["auto", "dls"]
    for info in infos:
        with pytest.raises(dataclasses.FrozenInstanceError):
            info.capabilities.batch = True  # type: ignore[misc]
    assert solver_info("nlp").capabilities.hard_constraints
    assert solver_info("analytic").capabilities.all_solutions
    assert not solver_info("analytic").capabilities.several_goals
    assert not solver_info("ccd").capabilities.solves(GoalKind.LOOK_AT)
    assert solver_info("dls").capabilities.solves(GoalKind.LOOK_AT)
    with pytest.raises(UnknownNameError, match="dls"):
        solver_info("dsl")


def test_cli_help_lists_every_registered_solver(capsys: pytest.CaptureFixture[str]) -> None:
    try:
        main(["ik", "--help"])
    except SystemExit:
        pass
    text = "".join(capsys.readouterr().out.split())  # argparse wraps the help
    for info in solver_infos():
        assert "".join(f"{info.name}: {info.summary}".split()) in text
    assert "--look-atXYZ" in text and "--axisAXIS" in text


def test_requests_are_checked_against_capabilities() -> None:
    goal = PositionGoal([0.3, 0.1, 0.3])
    plane = OnPlane([0.0, 0.0, 0.3], [0.0, 0.0, 1.0])
    assert solver_for("auto", (goal,), (plane,)) == "nlp"  # the one solver that takes them
    assert solver_for("auto", (goal,)) == "auto"
    assert solver_for("dls", (goal,), (plane,)) == "dls"  # refused later, with the reason
    with pytest.raises(UnsupportedGoalError,
                       match=r"'dls' does not accept constraints \(1 given\); use nlp for "):
        check_request("dls", (goal,), (plane,))
    two = (PoseGoal(np.eye(4), frame="a"), PoseGoal(np.eye(4), frame="b"))
    with pytest.raises(UnsupportedGoalError, match="'analytic' takes one goal at a time, got 2; "
                                                   "use dls, pinv, jt, ccd, ccd-jt or nlp"):
        check_request("analytic", two)
    with pytest.raises(UnsupportedGoalError, match="'analytic' cannot solve orientation goals"):
        check_request("analytic", (OrientationGoal(np.eye(3)),))
    with pytest.raises(InputError, match="solve_batch supports the solvers auto, dls, pinv, jt, "
                                         "ccd, ccd-jt; got 'nlp'"):
        solve_batch(load_arm("ur5e"), [goal], solver="nlp")


def test_cli_asks_capabilities(capsys: pytest.CaptureFixture[str]) -> None:
    xyz = ["--xyz", "0.3", "0.1", "0.3"]
    assert main(["ik", "ur5e", *xyz, "--all", "--solver", "dls"]) == 2
    assert "use it with --solver analytic" in capsys.readouterr().err
    # auto with a constraint runs the solver that takes constraints
    assert main(["ik", "ur5e", *xyz, "--plane", "0", "0", "0.3", "0", "0", "1", "--json"]) == 0
    assert '"solver": "nlp"' in capsys.readouterr().out
    assert main(["ik", "ur5e", *xyz, "--plane", "0", "0", "0.3", "0", "0", "1",
                 "--solver", "ccd"]) == 2
    assert "'ccd' does not accept constraints" in capsys.readouterr().err


def test_one_goal_kind_numbering_everywhere() -> None:
    import importlib

    from armctl.ik import _residual
    from armctl.ik.analytic import _polish

    assert importlib.import_module("armctl.ik.analytic.classify").GoalKind is GoalKind
    for module in (_residual, _polish):
        names = [k.name for k in GoalKind if hasattr(module, k.name)]
        assert len(names) >= 3
        for name in names:
            assert getattr(module, name) == GoalKind[name].value, (module.__name__, name)


def test_goal_kinds_are_registered_by_their_classes() -> None:
    classes = goal_classes()
    assert [c.kind for c in classes] == sorted(GoalKind)
    for cls in classes:
        assert goal_class(cls.kind) is cls and cls.kind.label == cls.label
    for attr in ("label", "file_type"):
        values = [getattr(c, attr) for c in classes]
        assert len(set(values)) == len(values), attr
    flags = [a.flag for c in classes for a in c.cli_arguments]
    assert len(set(flags)) == len(flags)
    with pytest.raises(InputError, match="not a goal kind"):
        goal_class(99)
    with pytest.raises(TypeError, match="POSITION belongs to PositionGoal"):

        @dataclasses.dataclass(frozen=True)
        class Clash(PositionGoal):
            kind = GoalKind.POSITION


def test_goal_subclasses_keep_their_kind_and_kindless_goals_are_refused() -> None:
    arm = load_arm("ur5e")

    @dataclasses.dataclass(frozen=True)
    class Labelled(PositionGoal):
        note: str = ""

    target = arm.fk(arm.middle() + 0.2)[:3, 3]
    res = arm.ik(Labelled(target, note="cup"), solver="dls", options=IKOptions(seed=1))
    assert res.success and np.linalg.norm(arm.fk(res.q)[:3, 3] - target) <= 1e-5

    @dataclasses.dataclass(frozen=True)
    class Kindless(Goal):
        pass

    with pytest.raises(InputError, match="Kindless has no goal kind"):
        arm.ik(Kindless(), solver="dls")


def test_the_documented_capability_table_is_the_registry() -> None:
    from armctl_testpaths import REPO

    def kinds(c: Capabilities) -> str:
        ks = c.goal_kinds
        return "all" if ks is None else ", ".join(k.label for k in sorted(ks))

    def yes(flag: bool) -> str:
        return "yes" if flag else "no"

    doc = (REPO / "docs" / "ik-goals.md").read_text()
    for info in solver_infos():
        c = info.capabilities
        row = (f"| `{info.name}` | {kinds(c)} | {yes(c.several_goals)} | "
               f"{yes(c.hard_constraints)} | {yes(c.all_solutions)} | {yes(c.batch)} | "
               f"{yes(c.nullspace)} | {yes(c.time_limit)} |")
        assert row in doc, row
