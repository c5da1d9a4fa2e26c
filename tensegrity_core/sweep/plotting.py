"""Plots of a sweep's table against its varied quantities (matplotlib, Agg backend).

One panel per numeric result (at most :data:`MAX_PANELS`, in the sweep's order):

- one varied quantity with several values: the result over it (a line with markers; a log
  axis for a log grid);
- two: a heat map over both (rows the first quantity, columns the second; cells without a
  value are grey);
- random samples: a histogram of the result over the points that have it.

Axes name the varied quantities and the results with their units
(:mod:`~tensegrity_core.sweep.units`); a boolean result is drawn as its two categories
(false, true; two colours in a heat map), a count with whole-number ticks.

Every point with a finite value is drawn, whatever its status (a failed form-finding still
has its smallest eigenvalue and its ``stable: false``), except a ``violated`` one: its run
broke an invariant of the physics, so its values are not results. The panel's title counts
the points that are not ``ok``, and the violated ones.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from tensegrity_core.sweep.errors import SweepError
from tensegrity_core.sweep.points import Quantity
from tensegrity_core.sweep.spec import ALWAYS_KEPT
from tensegrity_core.sweep.task import RowStatus
from tensegrity_core.sweep.units import quantity_label

if TYPE_CHECKING:
    from tensegrity_core.sweep.spec import Plan, Sweep

MAX_PANELS = 6


def plotted_columns(plan: Plan, wanted: Sequence[str] | None = None) -> list[str]:
    """The result columns to plot: ``wanted`` (checked), else every numeric one, else (a sweep
    that keeps no result but the one in every row) ``run_time`` (:data:`~tensegrity_core.sweep.spec.ALWAYS_KEPT`)."""
    numeric = [c for c, t in plan.result_columns if t in ("float", "int", "bool")]
    if wanted:
        for c in wanted:
            if c not in (*numeric, ALWAYS_KEPT):
                raise SweepError(f"no numeric result column {c!r} to plot; columns: {', '.join([*numeric, ALWAYS_KEPT])}")
        return list(wanted)
    return numeric[:MAX_PANELS] or [ALWAYS_KEPT]


def _label(v: object) -> str:
    return f"{v:.3g}" if isinstance(v, float) else str(v)


def column_unit(plan: Plan, column: str) -> str:
    """The unit of a result column (``""`` for a boolean, ``?`` when unknown)."""
    if dict(plan.result_columns).get(column) == "bool":
        return ""
    return "s" if column == ALWAYS_KEPT else plan.result_units.get(column) or "?"


def column_label(plan: Plan, column: str) -> str:
    """A result column with its unit: ``first_fold_time [s]``, ``slack_members [count]``; a
    boolean column is its name alone (its values are the categories false and true)."""
    unit = column_unit(plan, column)
    return f"{column} [{unit}]" if unit else column


def plot_sweep(table: Any, sweep: Sweep, path: str | Path, columns: Sequence[str] | None = None,
               plan: Plan | None = None) -> Path:
    """Write :func:`sweep_figure` to ``path`` (PNG)."""
    import matplotlib.pyplot as plt

    fig = sweep_figure(table, sweep, columns, plan)
    path = Path(path)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def sweep_figure(table: Any, sweep: Sweep, columns: Sequence[str] | None = None, plan: Plan | None = None) -> Any:
    """A matplotlib figure of ``table`` (from ``run_sweep(sweep)``); see the module docstring.
    ``plan``: the sweep's prepared plan, if the caller has it (else prepared here)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    if plan is None:
        from tensegrity_core.sweep.spec import prepare

        plan = prepare(sweep)
    columns = plotted_columns(plan, columns)
    axes_q = [q for q in sweep.quantities if not q.random and len(q.values) > 1]
    if sweep.random:
        mode = "hist"
    elif len(axes_q) == 1:
        mode = "line"
    elif len(axes_q) == 2:
        mode = "heat"
    else:
        raise SweepError(f"--plot draws results over one or two varied quantities (or histograms of random "
                         f"samples); this sweep varies {len(axes_q)} with several values: plot its table yourself")
    class2 = sweep.base.model_kind == "class2"
    kinds = {**dict(plan.result_columns), ALWAYS_KEPT: "float"}
    n = len(columns)
    ncols = min(n, 3)
    nrows = math.ceil(n / ncols)
    fig, axs = plt.subplots(nrows, ncols, figsize=(5.4 * ncols, 4.4 * nrows), squeeze=False)
    ok = table["status"] == RowStatus.OK
    violated = (table["status"] == RowStatus.VIOLATED).to_numpy()
    for ax, column in zip(axs.flat, columns):
        values = np.where(violated, np.nan, table[column].astype("float64").to_numpy(na_value=np.nan))
        failed = int((~ok).sum())
        note = f" ({failed} of {len(table)} points not ok" if failed else ""
        note += f", {int(violated.sum())} violated: not drawn)" if violated.any() else ")" if failed else ""
        label = column_label(plan, column)
        if mode == "hist":
            _histogram(ax, values, kinds[column], label, column_unit(plan, column))
        elif mode == "line":
            _line(ax, table, axes_q[0], values, kinds[column], label, class2)
        elif _heat_map(fig, ax, table, axes_q, values, kinds[column], label, class2):
            note += "; grey: no value"
        ax.set_title(f"{column}{note}", fontsize=9)
    for ax in list(axs.flat)[n:]:
        ax.set_visible(False)
    kind = {"hist": f"{len(table)} random samples", "line": "over one quantity", "heat": "over two quantities"}[mode]
    fig.suptitle(f"{sweep.name}: {sweep.computation}, {kind}", fontsize=11)
    fig.tight_layout()
    return fig


def _categorical(axis: Any) -> None:
    """A boolean axis: the two categories, not a scale."""
    axis.set_ticks([0, 1], ["false", "true"])


def _histogram(ax: Any, values: NDArray[np.float64], kind: str, label: str, unit: str) -> None:
    data = values[np.isfinite(values)]
    bins: NDArray[np.float64] | int
    if kind in ("int", "bool") and len(data):     # one bar per integer (or per category)
        bins = np.arange(min(data.min(), 0 if kind == "bool" else data.min()) - 0.5,
                         max(data.max(), 1 if kind == "bool" else data.max()) + 1.5)
    else:
        bins = max(10, min(50, int(math.sqrt(max(len(data), 1))) * 2))
    ax.hist(data, bins=bins, color="tab:blue", label="points")
    if len(data) and kind != "bool":
        u = "" if unit in ("1", "count") else f" {unit}"
        ax.axvline(float(np.mean(data)), color="k", lw=1, label=f"mean {np.mean(data):.4g}{u}, std {np.std(data):.2g}{u}")
    if kind == "bool":
        _categorical(ax.xaxis)
    elif kind == "int":
        from matplotlib.ticker import MaxNLocator

        ax.xaxis.set_major_locator(MaxNLocator(integer=True))
    ax.legend(fontsize=8)
    ax.set_xlabel(label)
    ax.set_ylabel("points [count]")


def _line(ax: Any, table: Any, q: Quantity, values: NDArray[np.float64], kind: str, label: str, class2: bool) -> None:
    x = table[q.column].to_numpy()
    keep = np.isfinite(values)
    numeric = all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in q.values)
    xs = x[keep].astype(float) if numeric else [str(v) for v in x[keep]]
    ax.plot(xs, values[keep], "o-", ms=3, label="a point (its value)")
    if q.log:
        ax.set_xscale("log")
    if kind == "bool":
        _categorical(ax.yaxis)
        ax.set_ylim(-0.3, 1.3)
    ax.set_xlabel(quantity_label(q, class2=class2))
    ax.set_ylabel(label)
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)


def _heat_map(fig: Any, ax: Any, table: Any, axes_q: list[Quantity], values: NDArray[np.float64], kind: str,
              label: str, class2: bool) -> bool:
    """Rows the first quantity, columns the second; a boolean in two colours, a count with
    whole-number ticks, cells without a value grey. Whether there are grey cells (the
    panel's title then says what grey means)."""
    import matplotlib
    from matplotlib.colors import BoundaryNorm, ListedColormap
    from matplotlib.ticker import MaxNLocator

    qa, qb = axes_q
    ia = {_label(v): i for i, v in enumerate(qa.values)}
    ib = {_label(v): i for i, v in enumerate(qb.values)}
    grid = np.full((len(qa.values), len(qb.values)), np.nan)
    for a, b, v in zip(table[qa.column], table[qb.column], values):
        grid[ia[_label(a)], ib[_label(b)]] = v
    if kind == "bool":
        cmap = ListedColormap(["tab:red", "tab:green"]).with_extremes(bad="0.85")
        norm = BoundaryNorm([-0.5, 0.5, 1.5], 2)
    else:
        cmap, norm = matplotlib.colormaps["viridis"].with_extremes(bad="0.85"), None
    im = ax.imshow(np.ma.masked_invalid(grid), origin="lower", aspect="auto", cmap=cmap, norm=norm,
                   interpolation="nearest")
    bar = fig.colorbar(im, ax=ax, label=label)
    if kind == "bool":
        _categorical(bar.ax.yaxis)
    elif kind == "int":
        bar.ax.yaxis.set_major_locator(MaxNLocator(integer=True))
    for q, setter, labels in ((qb, ax.set_xticks, ax.set_xlabel), (qa, ax.set_yticks, ax.set_ylabel)):
        step = max(1, math.ceil(len(q.values) / 6))
        ticks = list(range(0, len(q.values), step))
        setter(ticks, [_label(q.values[i]) for i in ticks])
        labels(quantity_label(q, class2=class2))
    return bool(np.isnan(grid).any())
