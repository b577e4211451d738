"""Kernels that numba compiles when first asked for, with interpreted twins for a few calls.

A kernel module defines its kernels as plain Python functions decorated with
:meth:`KernelSet.kernel`, then calls :meth:`KernelSet.finish` with its ``globals()`` and sets
its module ``__getattr__`` to :meth:`KernelSet.getattr`. Importing the module imports neither
numba nor compiles anything; the first time any kernel is read from the module
(``module.fk_into``, ``from module import fk_into``), numba is imported and every kernel of the
module becomes a numba dispatcher in the module's namespace (each compiled, or loaded from
numba's cache, on its first call), so calls between kernels are compiled calls.

:meth:`KernelSet.interpreted` gives the same functions run by the Python interpreter, calling
each other: the same operations in the same order, so the same results, much slower per call
but with nothing to load. A process that computes a handful of poses (``armctl fk``) is done
with them before numba would have finished loading its compiled kernels (about half a second).
"""

from __future__ import annotations

import importlib
import types
from collections.abc import Callable
from typing import Any

__all__ = ["KernelSet"]


class KernelSet:
    """The kernels of one module.

    Args:
        module: The module's name (for messages).
    """

    def __init__(self, module: str) -> None:
        self.module = module
        self._py: dict[str, Callable[..., Any]] = {}
        self._options: dict[str, dict[str, Any]] = {}
        self._namespace: dict[str, Any] | None = None
        self._compiled = False
        self._interpreted: dict[str, Any] | None = None
        self._borrowed: dict[str, tuple[str, str]] = {}

    def kernel(self, **options: Any) -> Callable[[Callable[..., Any]], Callable[..., Any]]:
        """Decorator: a kernel, compiled with ``numba.njit(**options)`` when first asked for."""

        def wrap(fn: Callable[..., Any]) -> Callable[..., Any]:
            self._py[fn.__name__] = fn
            self._options[fn.__name__] = options
            return fn

        return wrap

    def borrow(self, local: str, module: str, name: str) -> None:
        """Let this module's kernels call kernel ``name`` of another kernel ``module`` as ``local``.

        Compiled kernels call the other module's compiled kernel; interpreted ones its
        interpreted twin (the other module must have a module-level ``interpreted`` function).
        """
        self._borrowed[local] = (module, name)

    def finish(self, namespace: dict[str, Any]) -> None:
        """Take the kernels out of the module's namespace (``globals()``).

        Reading one from the module then goes through :meth:`getattr`, which compiles them.
        """
        for name in self._py:
            del namespace[name]
        self._namespace = namespace

    @property
    def names(self) -> frozenset[str]:
        """The kernels' names."""
        return frozenset(self._py)

    def compile(self) -> None:
        """Make every kernel a numba dispatcher in the module's namespace (idempotent).

        Each is compiled, or loaded from numba's cache, on its first call.
        """
        if self._compiled:
            return
        if self._namespace is None:
            raise RuntimeError(f"{self.module}: KernelSet.finish was not called")
        import numba

        for local, (module, name) in self._borrowed.items():
            self._namespace[local] = getattr(importlib.import_module(module), name)
        for name, fn in self._py.items():  # fn's globals are the module's namespace
            self._namespace[name] = numba.njit(**self._options[name])(fn)
        self._compiled = True

    def getattr(self, name: str) -> Any:
        """The module's ``__getattr__``: a kernel (compiled), else AttributeError."""
        if name not in self._py:
            raise AttributeError(f"module {self.module!r} has no attribute {name!r}")
        self.compile()
        assert self._namespace is not None
        return self._namespace[name]

    def interpreted(self, name: str) -> Callable[..., Any]:
        """Kernel ``name`` run by the Python interpreter (calling the other kernels likewise)."""
        if self._interpreted is None:
            if self._namespace is None:
                raise RuntimeError(f"{self.module}: KernelSet.finish was not called")
            ns = dict(self._namespace)
            for local, (module, other) in self._borrowed.items():
                ns[local] = importlib.import_module(module).interpreted(other)
            for kname, fn in self._py.items():
                ns[kname] = types.FunctionType(fn.__code__, ns, fn.__name__, fn.__defaults__,
                                               fn.__closure__)
            self._interpreted = ns
        if name not in self._py:
            raise AttributeError(f"module {self.module!r} has no kernel {name!r}")
        kernel: Callable[..., Any] = self._interpreted[name]
        return kernel
