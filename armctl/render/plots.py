"""Plot helpers with one consistent style, for every PNG that armctl writes.

Figures are made without pyplot (a :class:`matplotlib.figure.Figure` on an Agg canvas), so they
work headless, need no display, and leave no global state behind. Typical use::

    from armctl.render.plots import new_figure, save_figure, style_axes, color

    fig, (ax,) = new_figure()
    ax.plot(x, y, color=color(0), label="dls")
    style_axes(ax, title="IK error", xlabel="iteration", ylabel="error [m]", log_y=True)
    save_figure(fig, "ik_error.png")

matplotlib is imported inside the functions; importing this module costs nothing.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

from armctl.render.errors import MissingToolError, OutputError

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

__all__ = [
    "IMAGE_SUFFIXES",
    "PALETTE",
    "bar_chart",
    "cdf_plot",
    "check_output",
    "color",
    "new_figure",
    "save_figure",
    "style_axes",
]

#: The colour cycle (colour-blind friendly, Okabe-Ito order), as hex strings.
PALETTE: tuple[str, ...] = (
    "#0072B2", "#E69F00", "#009E73", "#D55E00", "#CC79A7", "#56B4E9", "#F0E442", "#000000",
)

#: File types that :func:`save_figure` writes.
IMAGE_SUFFIXES: tuple[str, ...] = (".png", ".svg", ".pdf", ".jpg", ".jpeg")

_FONT_SIZE = 9.0


def color(index: int) -> str:
    """The ``index``-th colour of :data:`PALETTE` (cycling)."""
    return PALETTE[index % len(PALETTE)]


def check_output(path: str | Path, suffixes: Sequence[str] = IMAGE_SUFFIXES) -> Path:
    """Check that a file of this type can be written at ``path``, before any work is done.

    Args:
        path: The output file.
        suffixes: Accepted file suffixes (lower case, with the dot).

    Returns:
        The path.

    Raises:
        OutputError: For an unknown suffix, a missing or unwritable folder, or a path that is a
            folder.
    """
    p = Path(path)
    if p.is_dir():
        raise OutputError(p, "it is a folder", "give a file name")
    if p.suffix.lower() not in suffixes:
        raise OutputError(p, f"unknown file type {p.suffix or '(none)'!r}",
                          f"use one of {', '.join(suffixes)}")
    parent = p.parent if str(p.parent) else Path()
    if parent.exists() and not parent.is_dir():
        raise OutputError(p, f"{parent} is a file, not a folder", "choose another location")
    if not parent.is_dir():
        raise OutputError(p, f"the folder {parent} does not exist", "create it first")
    if not os.access(parent, os.W_OK) or (p.exists() and not os.access(p, os.W_OK)):
        raise OutputError(p, "permission denied", "choose a writable location")
    return p


def _require_matplotlib() -> None:
    try:
        import matplotlib  # noqa: F401
    except ImportError as exc:
        raise MissingToolError("drawing needs matplotlib: pip install 'armctl[render]'") from exc


def new_figure(rows: int = 1, cols: int = 1, *, size: tuple[float, float] | None = None,
               dpi: float = 110, projection: str | None = None) -> tuple[Figure, list[Axes]]:
    """A headless figure with a grid of axes in the armctl style.

    Args:
        rows: Rows of axes.
        cols: Columns of axes.
        size: Figure size in inches; 4.2 x 3.4 per axes when ``None``.
        dpi: Resolution [dots per inch].
        projection: ``"3d"`` for 3-D axes, ``None`` for 2-D.

    Returns:
        The figure and its axes, row by row.
    """
    _require_matplotlib()
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=size or (4.2 * cols, 3.4 * rows), dpi=dpi, layout="constrained")
    FigureCanvasAgg(fig)
    axes = [fig.add_subplot(rows, cols, i + 1, projection=projection) for i in range(rows * cols)]
    for ax in axes:
        ax.tick_params(labelsize=_FONT_SIZE - 1)
    return fig, axes


def style_axes(ax: Axes, title: str | None = None, xlabel: str | None = None,
               ylabel: str | None = None, *, log_y: bool = False, legend: bool = False,
               grid: bool = True) -> None:
    """Apply the armctl style: titles, unit-bearing labels, a light grid, optional log scale."""
    if title:
        ax.set_title(title, fontsize=_FONT_SIZE + 1)
    if xlabel:
        ax.set_xlabel(xlabel, fontsize=_FONT_SIZE)
    if ylabel:
        ax.set_ylabel(ylabel, fontsize=_FONT_SIZE)
    if log_y:
        ax.set_yscale("log")
    if grid:
        ax.grid(True, color="#dddddd", linewidth=0.6)
        ax.set_axisbelow(True)
    if legend:
        ax.legend(fontsize=_FONT_SIZE - 1, frameon=False)


def bar_chart(ax: Axes, labels: Sequence[str], values: npt.ArrayLike,
              errors: npt.ArrayLike | None = None, *, value_format: str = "{:.3g}") -> None:
    """Bars in palette colours with their values written on top.

    Args:
        ax: The axes.
        labels: One label per bar.
        values: Bar heights.
        errors: Optional error bar half-heights.
        value_format: Format of the printed values.
    """
    vals = np.asarray(values, dtype=float)
    x = np.arange(len(vals))
    bars = ax.bar(x, vals, color=[color(i) for i in range(len(vals))],
                  yerr=None if errors is None else np.asarray(errors, dtype=float), capsize=3)
    ax.set_xticks(x, list(labels), rotation=20 if len(vals) > 4 else 0, fontsize=_FONT_SIZE - 1)
    ax.bar_label(bars, labels=[value_format.format(v) for v in vals], fontsize=_FONT_SIZE - 2)


def cdf_plot(ax: Axes, values: npt.ArrayLike, label: str, index: int = 0,
             linestyle: str = "-") -> None:
    """Empirical cumulative distribution of ``values`` (fraction of runs at or below a value).

    Args:
        ax: The axes.
        values: The samples.
        label: Legend label.
        index: Palette index of the line colour.
        linestyle: A matplotlib line style.
    """
    v = np.sort(np.asarray(values, dtype=float).ravel())
    frac = np.arange(1, len(v) + 1) / max(len(v), 1)
    ax.step(v, frac, where="post", label=label, color=color(index),
            linestyle=linestyle)
    ax.set_ylim(0.0, 1.02)


def save_figure(fig: Figure, path: str | Path, dpi: float | None = None) -> Path:
    """Write a figure (PNG, SVG, PDF, JPEG by suffix).

    Raises:
        OutputError: If the file cannot be written.
    """
    p = check_output(path)
    try:
        fig.savefig(p, dpi=dpi or fig.dpi, facecolor="white")
    except OSError as exc:
        raise OutputError(p, str(exc), "choose a writable location") from exc
    return p
