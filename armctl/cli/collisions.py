"""``armctl collisions``: show, regenerate and store an arm's allowed-collision matrix."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import TYPE_CHECKING, Any

from armctl.cli._common import add_config, add_json, emit, nonnegative_int, positive_int, table
from armctl.cli._scene import add_scene_option
from armctl.errors import InputError

if TYPE_CHECKING:
    from armctl.arm import Arm
    from armctl.collision.matrix import MatrixDiff, PairCounts
    from armctl.config.scene import AllowedPair, CollisionSpec

ORDER = 15

#: Random configurations sampled by ``--generate`` unless ``--samples`` says otherwise (the
#: library's default, :data:`armctl.collision.allowed.DEFAULT_SAMPLES`, which this module does
#: not import at start-up).
_SAMPLES = 20000


def register(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Add ``collisions``."""
    p = sub.add_parser(
        "collisions", help="show or regenerate the allowed-collision matrix of an arm",
        description="Show the allowed-collision matrix in force for an arm: the link pairs "
        "(and link-table pairs) that are never checked, each with its reason (adjacent, always, "
        "default, never, user), and how many pairs stay checked. With --generate, sample random "
        "configurations anew and compare the result with the file's matrix; with --write also, "
        "store it as the 'collision:' section of the arm's YAML file (hand-made 'user' pairs "
        "are kept; the rest of the file, comments included, is left as it is). See "
        "docs/collision.md.")
    add_config(p)
    p.add_argument("--generate", action="store_true",
                   help="find the matrix anew by sampling random configurations")
    p.add_argument("--samples", type=positive_int, metavar="N", default=None,
                   help=f"with --generate: how many configurations (default {_SAMPLES})")
    p.add_argument("--seed", type=nonnegative_int, metavar="N", default=None,
                   help="with --generate: random seed (default 0; the same seed gives the "
                        "same matrix)")
    p.add_argument("--write", action="store_true",
                   help="with --generate: write the matrix into the arm's YAML file")
    add_scene_option(p)  # its table decides the link-table pairs; its obstacles are counted
    add_json(p)
    p.set_defaults(func=cmd_collisions)


def _check_options(args: argparse.Namespace) -> None:
    """Refuse options that only apply with ``--generate``."""
    if args.generate:
        return
    given = [name for name, value in (("--samples", args.samples), ("--seed", args.seed))
             if value is not None]
    if args.write:
        given.insert(0, "--write")
    if given:
        what = {"--write": "stores the matrix that --generate finds",
                "--samples": "how many configurations --generate samples",
                "--seed": "the random seed of --generate's sampling"}
        raise InputError(f"{' and '.join(given)} only {'matters' if len(given) == 1 else 'matter'}"
                         f" with --generate ({'; '.join(f'{g}: {what[g]}' for g in given)}); "
                         "without --generate the matrix in force is shown as the checks use "
                         "it: add --generate to sample a new matrix")


#: The chance [0, 1] that the sampling may miss a pair with; see :func:`_missable`.
_MISS_CHANCE = 0.05


def _missable(samples: int) -> float:
    """The share of the joint space [0, 1] a pair may touch in and still be missed.

    ``samples`` uniform configurations all miss a region that fills a share ``p`` of the joint
    space with probability ``(1 - p) ** samples``; this is the ``p`` at which that is
    :data:`_MISS_CHANCE` (about ``3 / samples``).
    """
    return 1.0 - _MISS_CHANCE ** (1.0 / samples)


def _few_samples_line(samples: int, default: int) -> str | None:
    """What fewer samples than the default mean for the matrix, or ``None``."""
    if samples >= default:
        return None
    return (f"only {samples} samples: 1 time in {round(1 / _MISS_CHANCE)} they all miss a pair "
            f"that touches in {_missable(samples):.1%} of the joint space, and a pair that "
            "neither they nor the local search bring into contact becomes 'never' and is no "
            f"longer checked; the default {default} samples bring that share down to "
            f"{_missable(default):.3%}: use them before --write")


def _writable_file(arm: Arm) -> Path:
    """The arm's YAML file, refusing bundled configs and URDFs before anything is sampled.

    Raises:
        ConfigError: For an arm without a YAML file or a bundled arm, saying what to do.
    """
    from armctl.errors import ConfigError, KeyPath

    file = arm.spec.file
    if file is None:
        raise InputError(f"arm {arm.name!r} was not loaded from a file: there is no file to "
                         "write the matrix into")
    if file.suffix.lower() not in (".yaml", ".yml"):
        raise ConfigError("--write stores the matrix in an armctl YAML file, and this file is "
                          "not one", KeyPath(file),
                          f"convert it first ('armctl convert {file} -o {file.stem}.yaml') and "
                          "give the YAML file as CONFIG")
    if _is_bundled(file):
        raise ConfigError(f"{file.name} is a bundled arm config, part of the installed armctl "
                          "package; it is not written", KeyPath(file),
                          _copy_hint(file))
    return file


def _copy_hint(file: Path) -> str:
    return (f"copy it first ('cp {file} ./{file.name}'), then run 'armctl collisions "
            f"./{file.name} --generate --write' and give ./{file.name} as CONFIG from then on")


def _pairs(count: int) -> str:
    return f"{count} pair" if count == 1 else f"{count} pairs"


def _pair_rows(pairs: tuple[AllowedPair, ...]) -> list[list[str]]:
    return [[f"{p.a} / {p.b}", p.reason.value, p.note] for p in pairs]


def _pair_data(p: AllowedPair) -> dict[str, Any]:
    return {"links": [p.a, p.b], "reason": p.reason.value, "note": p.note}


def _counts_text(allowed: int, c: PairCounts) -> str:
    parts = [f"{c.links_checked} of {c.links} link-link"]
    if c.table:
        parts.append(f"{c.table_checked} of {c.table} link-table")
    if c.obstacles:
        parts.append(f"{c.obstacles} link-obstacle")
    return (f"{allowed} pairs allowed; {c.checked} of {c.candidates} pairs checked "
            f"({', '.join(parts)})")


def _counts_data(c: PairCounts) -> dict[str, int]:
    return {"links": c.links, "links_checked": c.links_checked, "table": c.table,
            "table_checked": c.table_checked, "obstacles": c.obstacles, "checked": c.checked,
            "candidates": c.candidates}


def _diff_lines(diff: MatrixDiff, in_file: CollisionSpec | None, table_on: bool) -> list[str]:
    from armctl.config.scene import TABLE

    if in_file is None:
        return ["the file has no collision: section: every pair above is new"]
    if diff.empty:
        return [f"same pairs and reasons as the file's matrix ({diff.unchanged} pairs)"]
    lines = [f"compared with the file's matrix: {len(diff.added)} added, {len(diff.removed)} "
             f"removed, {len(diff.changed)} changed, {diff.unchanged} unchanged"]
    rows = [["added", f"{p.a} / {p.b}", p.reason.value, "no longer checked"]
            for p in diff.added]
    rows += [["removed", f"{p.a} / {p.b}", p.reason.value,
              "checked from now on" if table_on or TABLE not in p.key else "no table in the scene"]
             for p in diff.removed]
    rows += [["changed", f"{c.new.a} / {c.new.b}", f"{c.old.reason.value} -> "
              f"{c.new.reason.value}", c.new.note] for c in diff.changed]
    lines.append(table(["change", "pair", "reason", "note"], rows))
    return lines


def _diff_data(diff: MatrixDiff) -> dict[str, Any]:
    return {"added": [_pair_data(p) for p in diff.added],
            "removed": [_pair_data(p) for p in diff.removed],
            "changed": [{"links": [c.new.a, c.new.b], "old_reason": c.old.reason.value,
                         "new_reason": c.new.reason.value, "note": c.new.note}
                        for c in diff.changed],
            "unchanged": diff.unchanged}


def cmd_collisions(args: argparse.Namespace) -> int:
    """Show the matrix in force, or generate one, compare it with the file's and store it."""
    _check_options(args)
    from armctl.cli._common import load_arm_arg
    from armctl.cli._scene import scene_arg
    from armctl.collision.allowed import DEFAULT_SAMPLES, generate_allowed
    from armctl.collision.matrix import diff_allowed, pair_counts, with_user_pairs
    from armctl.collision.model import scene_of
    from armctl.config.scene import AllowReason
    from armctl.config.scene_yaml import MAX_SAMPLES

    samples = DEFAULT_SAMPLES if args.samples is None else args.samples
    seed = 0 if args.seed is None else args.seed
    if samples > MAX_SAMPLES:
        raise InputError(f"--samples {samples} is more than {MAX_SAMPLES}: give fewer "
                         f"(the default is {DEFAULT_SAMPLES})")
    arm = load_arm_arg(args)
    file = _writable_file(arm) if args.write else arm.spec.file
    given = scene_arg(args, arm)
    scene = scene_of(arm) if given is None else given
    in_file = arm.spec.collision
    head = f"arm {arm.name!r}" + (f", file {file}" if file is not None else "")
    data: dict[str, Any] = {"arm": arm.name, "file": str(file) if file is not None else None,
                            "in_file": in_file is not None,
                            "scene": str(scene.file) if given is not None else None}
    lines = [head]
    if given is not None:
        lines.append(f"scene {scene.file} (its table decides the link-table pairs)")
    if not args.generate:
        if in_file is not None:
            shown = in_file
            how = (f"generated from {in_file.samples} samples" if in_file.samples else
                   "written by hand")
            lines.append(f"allowed-collision matrix from the file ({how})")
            data.update(source="file", samples=in_file.samples, seed=None)
        else:
            shown = generate_allowed(arm, scene, samples=samples, seed=seed)
            lines.append(f"none in the file: generated by sampling ({samples} samples, seed "
                         f"{seed}), as the collision checks do; to store it: "
                         f"{_how_to_store(file, args.config)}")
            data.update(source="generated", samples=samples, seed=seed)
    else:
        generated = generate_allowed(arm, scene, samples=samples, seed=seed)
        shown = with_user_pairs(generated, in_file)
        kept = sum(1 for p in (in_file.allowed if in_file is not None else ())
                   if p.reason is AllowReason.USER)
        lines.append(f"new allowed-collision matrix ({samples} samples, seed {seed}"
                     + (f"; kept {_pairs(kept)} marked 'user' in the file" if kept
                        else "")
                     + ")")
        few = _few_samples_line(samples, DEFAULT_SAMPLES)
        if few is not None:
            lines.append(few)
        data.update(source="generated", samples=samples, seed=seed, user_pairs_kept=kept,
                    missable_share=_missable(samples))
    lines.append("")
    lines.append(table(["pair", "reason", "note"], _pair_rows(shown.allowed)) if shown.allowed
                 else "(no pairs: every pair is checked)")
    counts = pair_counts(arm, scene, shown)
    lines.append("")
    lines.append(_counts_text(len(shown.allowed), counts))
    data.update(allowed=[_pair_data(p) for p in shown.allowed], pairs=_counts_data(counts))
    if args.generate:
        diff = diff_allowed(in_file, shown)
        lines.append("")
        lines += _diff_lines(diff, in_file, scene.table is not None)
        data["diff"] = _diff_data(diff)
        written = None
        if args.write:
            from armctl.config.collision_writer import replace_collision_section

            assert file is not None  # _writable_file returned it
            written = replace_collision_section(file, shown)
            lines.append(f"wrote the collision: section of {written} ({len(shown.allowed)} "
                         "pairs)")
        else:
            lines.append(f"not written: {_how_to_store(file, args.config)}")
        data["written"] = str(written) if written is not None else None
    emit(args, data, "\n".join(lines))
    return 0


def _is_bundled(file: Path) -> bool:
    from armctl.config import bundled_configs_dir

    return file.resolve().parent == bundled_configs_dir()


def _how_to_store(file: Path | None, config: str) -> str:
    """How to store a generated matrix in the arm's file."""
    if file is None:
        return "the arm has no file to store it in"
    if file.suffix.lower() not in (".yaml", ".yml"):
        return (f"a URDF has no collision: section; convert it first ('armctl convert {file} "
                f"-o {file.stem}.yaml') and store the matrix in the YAML file")
    if _is_bundled(file):
        return _copy_hint(file)
    return f"'armctl collisions {config} --generate --write' writes its collision: section"
