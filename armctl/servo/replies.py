"""Matching status packets to the requests they answer, so that a late reply is never taken.

A status packet carries the servo id, the error byte and the data, but not the instruction or
the register it answers (Dynamixel 2.0 and Feetech alike). A reply that arrives after its
request's timeout therefore looks like the answer to the next request of the same servo and
length. :class:`ReplyLedger` removes that ambiguity:

* Every request whose reply did not arrive stays *pending*: ``(servo id, number of data bytes
  its reply will carry)``.
* A read chooses its **window** (start address and length) so that its reply length differs
  from every pending reply length of the servos it addresses: the register's own bytes when
  nothing is pending, else a few more bytes around them (the caller slices the register out).
  A reply is accepted only when its id and length match the request; a packet that matches a
  pending entry is a late reply, recorded against its servo and discarded.
* A servo answers its requests in order, so once a reply of servo ``s`` has been matched every
  earlier request to ``s`` has been answered or will never be: its pending entries are cleared.
* Requests whose reply length cannot vary (a write's acknowledgement, a ping) go out only when
  no reply of that length is pending for the servo; otherwise the caller first sends a
  *barrier*: a read with a distinguishable length whose matched reply clears the servo.

An entry is kept until its reply arrives (late) or a later reply of the servo is matched. A
corrupt packet settles nothing (it may have been another packet, the real reply still to come),
except for replies that carry nothing a stale one could hide (a ping's, a reboot's:
:meth:`ReplyLedger.unreadable`); after a corrupt write acknowledgement the driver reads the
register back instead of writing again. When a servo has too many entries (no read length is
left free), the driver drains the line until it stays quiet and forgets them
(:meth:`ReplyLedger.matched`).
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Iterable, Sequence
from dataclasses import dataclass

__all__ = ["ReplyLedger", "Window"]


@dataclass(frozen=True)
class Window:
    """The bytes a read asks for.

    Attributes:
        start: First address.
        length: Number of bytes (the reply's data length).
    """

    start: int
    length: int

    def slice(self, data: Sequence[int], address: int, size: int) -> list[int]:
        """The ``size`` bytes at ``address`` out of the window's ``data``."""
        lo = address - self.start
        return list(data[lo:lo + size])


class ReplyLedger:
    """Pending replies per servo (oldest first), late replies seen, failed attempts counted."""

    def __init__(self) -> None:
        self._pending: dict[int, list[int]] = {}
        self.late: Counter[int] = Counter()
        self.retries: Counter[int] = Counter()

    def pending(self, sid: int) -> frozenset[int]:
        """The reply lengths [bytes of data] still expected from servo ``sid``."""
        return frozenset(self._pending.get(sid, ()))

    def any_pending(self, ids: Iterable[int]) -> bool:
        """Whether a reply of any of ``ids`` is still expected."""
        pending = self._pending
        return bool(pending) and any(pending.get(sid) for sid in ids)

    def count_pending(self, sid: int) -> int:
        """How many requests to ``sid`` still await their reply."""
        return len(self._pending.get(sid, ()))

    def sent(self, sid: int, n: int) -> None:
        """A request to ``sid`` whose reply will carry ``n`` data bytes went out."""
        self._pending.setdefault(sid, []).append(n)

    def matched(self, sid: int) -> None:
        """A reply of ``sid`` was matched to its request: every earlier one is settled."""
        self._pending.pop(sid, None)

    def unreadable(self, sid: int, n: int) -> None:
        """The newest request to ``sid`` (reply length ``n``) got a corrupt reply: none follows.

        Only for requests whose reply carries nothing a stale one could hide (see
        :meth:`armctl.servo.driver.ServoBus._exchange`): the corrupt packet may have been
        another one, and the real reply may still come and answer the next such request.
        """
        entries = self._pending.get(sid, [])
        for i in range(len(entries) - 1, -1, -1):
            if entries[i] == n:
                del entries[i]
                return

    def take_late(self, sid: int, n: int) -> bool:
        """Whether a packet from ``sid`` with ``n`` data bytes answers an earlier request.

        If so, the oldest such pending entry is removed and the late reply is counted.
        """
        entries = self._pending.get(sid, [])
        if n not in entries:
            return False
        entries.remove(n)  # the oldest: replies come in order
        self.late[sid] += 1
        return True

    def window(self, ids: Iterable[int], address: int, size: int, memory_size: int
               ) -> Window | None:
        """A read window covering ``[address, address + size)`` whose length is not pending.

        Prefers the register's own bytes, then extends the end, then the start, within
        ``[0, memory_size)``.

        Returns:
            The window, or ``None`` when every possible length is pending.
        """
        busy: set[int] = set()
        for sid in ids:
            busy |= self.pending(sid)
        if size not in busy:
            return Window(address, size)
        for length in range(size + 1, memory_size + 1):
            if length in busy:
                continue
            end = min(memory_size, address + length)
            start = end - length
            if start >= 0:
                return Window(start, length)
        return None

    def count_retry(self, sid: int | None) -> None:
        """Count one failed attempt (timeout, corrupt or late reply) against servo ``sid``."""
        if sid is not None:
            self.retries[sid] += 1
