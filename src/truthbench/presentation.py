"""The one protocol of a result a person looks at: ``to_pandas(table=None)`` and
``plot(kind=None, ax=None) -> Figure``.

Every such result (identified modes, an update, an uncertainty model, a nonlinear
simulation, a time record, a study, ...) mixes in :class:`Presentable` and names its
tables and its figures, the default first::

    class UpdateResult(Presentable):
        TABLES = ("parameters", "history", "correlation")
        PLOTS = ("history", "correlation")

        def _table_parameters(self): ...          # -> pandas.DataFrame
        def _plot_history(self, ax, **options):   # -> matplotlib Figure
            fig, axes = figure_axes(ax, 2)
            ...

so ``result.to_pandas()`` is the default table, ``result.to_pandas("history")`` another,
``result.plot()`` the default figure, ``result.plot("correlation", ax=ax)`` another drawn
into the caller's axes; an unknown name is a ValueError listing the known ones
(:func:`choose`).

Library code never chooses a matplotlib backend (``matplotlib.use``): a new figure comes
from pyplot, which picks one itself (Agg when there is no display, the notebook's inline
backend in Jupyter). Only the command line and the report writers choose a backend and
write files.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import ClassVar

import numpy as np


def choose(owner: object, what: str, name: str | None, names: Sequence[str]) -> str:
    """``name``, or the first of ``names`` when None; a ValueError naming ``owner``'s type
    and the known names otherwise."""
    if name is None:
        return names[0]
    if name not in names:
        raise ValueError(f"{type(owner).__name__}: unknown {what} {name!r}; expected one of "
                         f"{', '.join(map(repr, names))}")
    return name


class Presentable:
    """Mixin of a result: :meth:`to_pandas` and :meth:`plot` by name (see the module)."""

    TABLES: ClassVar[tuple[str, ...]] = ()
    """Names of the tables, the default first; each is drawn by ``_table_<name>()``."""
    PLOTS: ClassVar[tuple[str, ...]] = ()
    """Names of the figures, the default first; each by ``_plot_<name>(ax, **options)``."""

    def to_pandas(self, table: str | None = None):
        """One of the result's tables (:attr:`TABLES`; None: the first).

        Returns
        -------
        pandas.DataFrame
        """
        return getattr(self, f"_table_{choose(self, 'table', table, self.TABLES)}")()

    def plot(self, kind: str | None = None, ax=None, **options):
        """One of the result's figures (:attr:`PLOTS`; None: the first), drawn on ``ax``
        (a matplotlib Axes, or an array of them for a figure of several panels) or on a
        new figure.

        Returns
        -------
        matplotlib.figure.Figure
        """
        return getattr(self, f"_plot_{choose(self, 'kind', kind, self.PLOTS)}")(ax, **options)


def figure_axes(ax=None, nrows: int = 1, ncols: int = 1, **subplots):
    """The figure and an array of ``nrows * ncols`` axes (flat) to draw on: a new pyplot
    figure (``subplots`` given to :func:`matplotlib.pyplot.subplots`), or the caller's
    axes (one Axes or an array of at least that many).

    Raises
    ------
    ValueError
        Fewer axes given than the figure has panels.
    """
    if ax is None:
        import matplotlib.pyplot as plt

        fig, axes = plt.subplots(nrows, ncols, squeeze=False, **subplots)
        return fig, axes.ravel()
    axes = np.ravel(np.asarray(ax, dtype=object))
    if axes.size < nrows * ncols:
        raise ValueError(f"this figure has {nrows * ncols} panels; got {axes.size} axes")
    return axes[0].figure, axes
