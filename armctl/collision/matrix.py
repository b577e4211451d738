"""Comparing and merging allowed-collision matrices, and counting the pairs they leave checked.

``armctl collisions CONFIG --generate`` compares a freshly sampled matrix with the one in the
arm's file (:func:`diff_allowed`), keeps the pairs the user declared by hand
(:func:`with_user_pairs`) and says how many pairs stay checked (:func:`pair_counts`).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

from armctl.collision.contact import ContactKind
from armctl.config.scene import TABLE, AllowedPair, AllowReason, CollisionSpec, SceneSpec
from armctl.kinematics.model import KinematicModel

__all__ = ["MatrixDiff", "PairCounts", "ReasonChange", "diff_allowed", "pair_counts",
           "with_user_pairs"]


@dataclass(frozen=True)
class ReasonChange:
    """A pair allowed in both matrices for different reasons.

    Attributes:
        old: The pair as the old matrix has it.
        new: The pair as the new matrix has it.
    """

    old: AllowedPair
    new: AllowedPair


@dataclass(frozen=True)
class MatrixDiff:
    """What changes from one matrix to another (pairs compared unordered; notes ignored).

    Attributes:
        added: Pairs allowed in the new matrix only (no longer checked).
        removed: Pairs allowed in the old matrix only (checked from now on).
        changed: Pairs allowed in both, for another reason.
        unchanged: How many pairs are allowed in both for the same reason.
    """

    added: tuple[AllowedPair, ...]
    removed: tuple[AllowedPair, ...]
    changed: tuple[ReasonChange, ...]
    unchanged: int

    @property
    def empty(self) -> bool:
        """Whether both matrices allow the same pairs for the same reasons."""
        return not (self.added or self.removed or self.changed)


def diff_allowed(old: CollisionSpec | None, new: CollisionSpec) -> MatrixDiff:
    """Compare two allowed-collision matrices.

    Args:
        old: The matrix in force (``None``: none, every pair of ``new`` is added).
        new: The new matrix.

    Returns:
        The added, removed and changed pairs, each in the order of its matrix.
    """
    before = {} if old is None else {p.key: p for p in old.allowed}
    after = {p.key: p for p in new.allowed}
    added = tuple(p for k, p in after.items() if k not in before)
    removed = tuple(p for k, p in before.items() if k not in after)
    changed = tuple(ReasonChange(before[k], p) for k, p in after.items()
                    if k in before and before[k].reason is not p.reason)
    same = sum(1 for k, p in after.items() if k in before and before[k].reason is p.reason)
    return MatrixDiff(added, removed, changed, same)


def with_user_pairs(new: CollisionSpec, old: CollisionSpec | None) -> CollisionSpec:
    """``new`` with the pairs that ``old`` declares by hand (reason ``user``).

    A hand-made pair wins over a sampled pair of the same links (the user's reason stands);
    it goes after the sampled pairs, in its old order.

    Args:
        new: A generated matrix.
        old: The matrix in the arm's file, or ``None``.

    Returns:
        The matrix to store; ``samples`` is ``new``'s.
    """
    user = [p for p in (old.allowed if old is not None else ()) if p.reason is AllowReason.USER]
    if not user:
        return new
    taken = {p.key for p in user}
    kept = tuple(p for p in new.allowed if p.key not in taken)
    return replace(new, allowed=kept + tuple(user))


@dataclass(frozen=True)
class PairCounts:
    """The link-level pairs of an arm in its scene, and how many a matrix leaves checked.

    Pairs of two links fixed to the base, and of such a link and the table, are never
    candidates: nothing can move them.

    Attributes:
        links: Candidate link-link pairs.
        links_checked: Of those, the pairs checked.
        table: Candidate link-table pairs (0 without a table).
        table_checked: Of those, the pairs checked.
        obstacles: Link-obstacle pairs (always checked; the matrix names only the table).
    """

    links: int
    links_checked: int
    table: int
    table_checked: int
    obstacles: int

    @property
    def checked(self) -> int:
        """Every checked pair: link-link, link-table and link-obstacle."""
        return self.links_checked + self.table_checked + self.obstacles

    @property
    def candidates(self) -> int:
        """Every candidate pair."""
        return self.links + self.table + self.obstacles


def pair_counts(model: KinematicModel, scene: SceneSpec, allowed: CollisionSpec) -> PairCounts:
    """Count the link-level pairs that ``allowed`` leaves checked.

    Args:
        model: The arm.
        scene: Its scene.
        allowed: The matrix.

    Returns:
        The counts (each link pair counted once, whatever number of capsules its links have).
    """
    from armctl.collision.model import CollisionModel

    def pairs(spec: CollisionSpec) -> tuple[set[frozenset[str]], set[frozenset[str]],
                                            set[frozenset[str]]]:
        cm = CollisionModel(model, scene, spec)
        own, table, other = set(), set(), set()
        for i in range(cm.pair_count):
            a, b, kind = cm.pair_names(i)
            key = frozenset((a, b))
            if kind is ContactKind.SELF:
                own.add(key)
            elif b == TABLE:
                table.add(key)
            else:
                other.add(key)
        return own, table, other

    all_own, all_table, all_other = pairs(CollisionSpec())
    own, table, _ = pairs(allowed)
    return PairCounts(len(all_own), len(own), len(all_table), len(table), len(all_other))
