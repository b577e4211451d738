"""Progress while numba compiles the numerical kernels.

The kernels (forward kinematics, the IK solvers) are compiled on their first use and cached on
disk, so only the first run after installing (or after a change to their source) compiles; that
can take tens of seconds on a slow machine. :func:`report_compiles` makes every compile that
lasts longer than ``delay`` say so on the ``armctl.kinematics.compile_progress`` logger (INFO),
then report how far it has got every ``every`` seconds and when it is done. Loading a cached
kernel is not a compile and says nothing.
"""

from __future__ import annotations

import importlib.abc
import importlib.machinery
import importlib.util
import logging
import sys
import threading
import time
from collections.abc import Callable, Sequence
from types import ModuleType
from typing import Any

__all__ = ["CompileRecord", "compile_records", "report_compiles", "report_compiles_once_loaded"]

log = logging.getLogger(__name__)

#: Installed once per process (numba's event registry is global).
_installed: _CompileProgress | None = None
_lock = threading.Lock()


class CompileRecord:
    """One kernel compile.

    Attributes:
        name: The kernel's qualified name (module and function).
        seconds: How long it took [s], the kernels it calls (compiled inside it) included.
        own_seconds: The same without those nested compiles [s].
    """

    __slots__ = ("name", "own_seconds", "seconds")

    def __init__(self, name: str, seconds: float, own_seconds: float) -> None:
        self.name = name
        self.seconds = seconds
        self.own_seconds = own_seconds

    def __repr__(self) -> str:
        return f"CompileRecord({self.name!r}, {self.seconds:.3f}, {self.own_seconds:.3f})"


def _name(event: Any) -> str:
    dispatcher = (event.data or {}).get("dispatcher")
    func = getattr(dispatcher, "py_func", None)
    if func is None:
        return "kernel"
    return f"{func.__module__}.{func.__qualname__}"


class _CompileProgress:
    """A numba ``numba:compile`` listener that times compiles and reports the long ones."""

    def __init__(self, delay: float, every: float) -> None:
        self.delay = delay
        self.every = every
        self.records: list[CompileRecord] = []
        #: The compiles under way, outermost first: name, start time, nested compile time.
        self._starts: list[list[Any]] = []
        self._timer: threading.Timer | None = None
        self._t0 = 0.0
        self._count = 0  # kernels compiled in the present outermost compile
        self._told = False

    # numba's Listener interface (the class is made a subclass in report_compiles) -----------
    def on_start(self, event: Any) -> None:
        name = _name(event)
        now = time.perf_counter()
        with _lock:
            if not self._starts:
                self._t0, self._count, self._told = now, 0, False
                self._schedule(self.delay, name)
            self._starts.append([name, now, 0.0])

    def on_end(self, event: Any) -> None:
        now = time.perf_counter()
        with _lock:
            if not self._starts:
                return
            name, start, nested = self._starts.pop()
            self.records.append(CompileRecord(name, now - start, now - start - nested))
            if self._starts:
                self._starts[-1][2] += now - start
            self._count += 1
            if self._starts:
                return
            if self._timer is not None:
                self._timer.cancel()
                self._timer = None
            told, count, total = self._told, self._count, now - self._t0
        if told:
            log.info("compiled %d numerical kernel%s in %.1f s (cached for the next runs)",
                     count, "" if count == 1 else "s", total)

    def _schedule(self, after: float, name: str) -> None:
        timer = threading.Timer(after, self._tick, args=(name,))
        timer.daemon = True
        self._timer = timer
        timer.start()

    def _tick(self, first: str) -> None:
        with _lock:
            if not self._starts:
                return
            told, self._told = self._told, True
            elapsed = time.perf_counter() - self._t0
            count, current = self._count, self._starts[-1][0]
            self._schedule(self.every, first)
        if not told:
            log.info("compiling the numerical kernels for %s (first run after installing; "
                     "cached afterwards, this can take a minute)...", first.rsplit(".", 1)[-1])
        else:
            log.info("still compiling: %d kernel%s done, now %s (%.0f s so far)...", count,
                     "" if count == 1 else "s", current.rsplit(".", 1)[-1], elapsed)


def report_compiles(delay: float = 1.0, every: float = 10.0) -> None:
    """Log the kernel compiles that last longer than ``delay`` seconds, with progress.

    Imports numba. Idempotent: later calls change nothing. Messages go to the
    ``armctl.kinematics.compile_progress`` logger at INFO level (the command line shows them
    on stderr).

    Args:
        delay: Seconds a compile may take before it is reported.
        every: Seconds between progress messages while compiling.
    """
    global _installed
    if _installed is not None:
        return
    from numba.core import event

    listener_class = type("CompileProgressListener", (_CompileProgress, event.Listener), {})
    listener = listener_class(delay, every)
    event.register("numba:compile", listener)
    _installed = listener


def compile_records() -> list[CompileRecord]:
    """The compiles seen since :func:`report_compiles` was called (empty before).

    In the order they finished: nested kernels before the kernel that calls them.
    """
    return list(_installed.records) if _installed is not None else []


class _ThenLoader(importlib.abc.Loader):
    """Runs a module's own loader, then a callback, then steps aside."""

    def __init__(self, loader: importlib.abc.Loader, then: Callable[[], None]) -> None:
        self.loader = loader
        self.then = then

    def create_module(self, spec: importlib.machinery.ModuleSpec) -> ModuleType | None:
        return self.loader.create_module(spec)

    def exec_module(self, module: ModuleType) -> None:
        module.__loader__ = self.loader  # the module keeps its own loader
        if module.__spec__ is not None:
            module.__spec__.loader = self.loader
        self.loader.exec_module(module)
        self.then()


class _OnImport(importlib.abc.MetaPathFinder):
    """Calls ``then`` right after the top-level module ``name`` is first imported."""

    def __init__(self, name: str, then: Callable[[], None]) -> None:
        self.name = name
        self.then = then

    def find_spec(self, fullname: str, path: Sequence[str] | None = None,
                  target: ModuleType | None = None) -> importlib.machinery.ModuleSpec | None:
        if fullname != self.name:
            return None
        if self in sys.meta_path:
            sys.meta_path.remove(self)
        spec = importlib.util.find_spec(fullname)
        if spec is not None and spec.loader is not None:
            spec.loader = _ThenLoader(spec.loader, self.then)
        return spec


def report_compiles_once_loaded(delay: float = 1.0, every: float = 10.0) -> None:
    """:func:`report_compiles`, once something imports numba (now if it is imported already).

    A process that never needs a compiled kernel then never imports numba for this.
    """
    if "numba" in sys.modules:
        report_compiles(delay, every)
    elif not any(isinstance(f, _OnImport) for f in sys.meta_path):
        sys.meta_path.insert(0, _OnImport("numba", lambda: report_compiles(delay, every)))
