"""Regenerate the ``collision:`` section of every bundled arm config (armctl/configs/*.yaml).

``armctl collisions CONFIG --generate --write`` refuses the bundled configs (they belong to
the installed package); this tool is how they get their matrix in the source tree: the same
sampling (``--samples``, default 20000, ``--seed``, default 0) and the same writer (only the
``collision:`` section changes; hand-made ``user`` pairs are kept). A comment line above the
section says how it was made. tests/collision/test_allowed.py checks that every shipped matrix
equals the regenerated one.

Usage: python tools/bundled_collisions.py [--arms so101 ur5e ...] [--samples N] [--seed N]
"""

from __future__ import annotations

import argparse

from armctl.arm import load_arm
from armctl.atomic_write import write_atomic
from armctl.collision.allowed import DEFAULT_SAMPLES, generate_allowed
from armctl.collision.matrix import diff_allowed, with_user_pairs
from armctl.collision.model import scene_of
from armctl.config import bundled_configs
from armctl.config.collision_writer import with_collision_section

#: The comment written above a new section (an existing section keeps the lines above it).
COMMENT = ("# Allowed-collision matrix: found by 'armctl collisions CONFIG --generate' ({samples} "
           "samples, seed {seed});\n# see docs/collision.md. Pairs with 'reason: user' are "
           "kept when it is regenerated.\n")


def main() -> None:
    """Regenerate and write the sections; print what changed per arm."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--arms", nargs="+", default=list(bundled_configs()))
    parser.add_argument("--samples", type=int, default=DEFAULT_SAMPLES)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    configs = bundled_configs()
    for name in args.arms:
        path = configs[name]
        arm = load_arm(path)
        old = arm.spec.collision
        new = with_user_pairs(generate_allowed(arm, scene_of(arm), samples=args.samples,
                                               seed=args.seed), old)
        diff = diff_allowed(old, new)
        text = path.read_text(encoding="utf-8")
        if old is None:
            sep = "" if text.endswith("\n") else "\n"
            text += sep + "\n" + COMMENT.format(samples=args.samples, seed=args.seed)
        write_atomic(path, with_collision_section(text, new, path))
        print(f"{name}: {len(new.allowed)} pairs ({len(diff.added)} added, "
              f"{len(diff.removed)} removed, {len(diff.changed)} changed)")


if __name__ == "__main__":
    main()
