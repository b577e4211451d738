"""The commands the build runs to compile the kernels: real command lines that move nothing."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest
from armctl_testpaths import REPO

from armctl.cli import _precompile, build_parser

#: Verbs that never move the arm (their command lines need no --dry-run).
_STILL = ("ik", "collisions", "status", "fk")


def _command_lines() -> list[tuple[str, tuple[str, ...]]]:
    return [(g, argv) for g, lines in _precompile.GROUPS.items() for argv in lines]


@pytest.mark.parametrize(("group", "argv"), _command_lines(),
                         ids=lambda v: v if isinstance(v, str) else " ".join(v))
def test_each_command_line_parses_and_moves_nothing(group: str, argv: tuple[str, ...],
                                                    tmp_path: Path) -> None:
    args = build_parser().parse_args([str(tmp_path) if a in ("{keys}", "{scene}") else a
                                      for a in argv])
    assert callable(getattr(args, "func", None))
    verb = argv[0]
    if verb == "teleop":  # moves only the simulated follower, for a bounded time
        assert args.sim and args.duration is not None and args.duration <= 1.0
    elif verb not in _STILL:
        assert args.dry_run, argv
    if verb == "status":
        assert args.sim and args.once


def test_the_build_runs_every_group() -> None:
    tree = ast.parse((REPO / "setup.py").read_text(encoding="utf-8"))
    groups = next(ast.literal_eval(node.value) for node in ast.walk(tree)
                  if isinstance(node, ast.Assign)
                  and any(getattr(t, "id", None) == "GROUPS" for t in node.targets))
    assert sorted(groups) == sorted(_precompile.GROUPS)


def test_an_unknown_group_is_refused(capsys: pytest.CaptureFixture[str]) -> None:
    assert _precompile.main(["no-such-group"]) == 2
    err = capsys.readouterr().err
    assert "no-such-group" in err and "analytic" in err and "numeric" in err
