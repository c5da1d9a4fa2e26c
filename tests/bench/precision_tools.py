"""Work-precision points, Pareto fronts and their plots (used by ``bench_precision``).

A :class:`Point` is one run of one method at one setting (a tolerance, a step): its error
against a reference, its wall time and its count of function evaluations (or
iterations). A point is *on the front* when no other point of the same study is both
at least as accurate and clearly faster (``slack``: 10 % of its time, the noise of
these machines). Reading a front: :func:`time_at_error` interpolates a method's time at
a given error (log-log, along its own curve), :func:`cost_per_digit` fits the factor of
time one more correct digit costs.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field

import numpy as np


@dataclass
class Point:
    study: str
    method: str
    setting: float                 # rtol, residual tolerance or difference step
    error: float                   # against the study's reference (inf: the run failed)
    seconds: float                 # best wall time of the run
    evaluations: int = 0           # right-hand sides, iterations or energy evaluations
    ok: bool = True
    default: bool = False          # the shipped default of a scene or function
    note: str = ""
    extra: dict = field(default_factory=dict)

    def as_dict(self) -> dict:
        d = asdict(self)
        for k in ("error", "seconds", "setting"):
            if not math.isfinite(d[k]):
                d[k] = None
        return d


def usable(points) -> list[Point]:
    return [p for p in points if p.ok and math.isfinite(p.error) and p.error > 0]


def pareto_front(points) -> list[Point]:
    """The points no other point beats in both time and error, fastest first."""
    front, best = [], math.inf
    for p in sorted(usable(points), key=lambda p: (p.seconds, p.error)):
        if p.error < best:
            front.append(p)
            best = p.error
    return front


def dominating(point: Point, points, slack: float = 0.1) -> list[Point]:
    """Points at least as accurate as ``point`` and faster by more than ``slack``."""
    return [q for q in usable(points) if q is not point and q.error <= point.error
            and q.seconds < (1.0 - slack) * point.seconds]


def time_at_error(points, method: str, error: float) -> float | None:
    """Wall time ``method`` needs for ``error``, interpolated log-log along its points
    (None outside the errors it reached)."""
    pts = sorted(((p.error, p.seconds) for p in usable(points) if p.method == method), reverse=True)
    if len(pts) < 1:
        return None
    errs = np.log10([e for e, _ in pts])
    secs = np.log10([s for _, s in pts])
    le = math.log10(error)
    if le > errs[0] + 1e-9 or le < errs[-1] - 1e-9:
        return None
    # errors need not fall monotonically with the tolerance: take the cheapest crossing
    best = None
    for i in range(len(pts) - 1):
        lo, hi = sorted((errs[i], errs[i + 1]))
        if lo - 1e-12 <= le <= hi + 1e-12:
            w = 0.0 if hi == lo else (le - errs[i]) / (errs[i + 1] - errs[i])
            t = 10 ** (secs[i] + w * (secs[i + 1] - secs[i]))
            best = t if best is None else min(best, t)
    if best is None and len(pts) == 1:
        best = 10 ** secs[0]
    return best


def cost_per_digit(points, method: str) -> float | None:
    """Factor by which ``method``'s time grows per extra correct digit (least-squares slope
    of log10 time against -log10 error over its usable points)."""
    pts = [(p.error, p.seconds) for p in usable(points) if p.method == method]
    if len(pts) < 2:
        return None
    x = -np.log10([e for e, _ in pts])
    y = np.log10([s for _, s in pts])
    if np.ptp(x) < 0.5:
        return None
    slope = np.polyfit(x, y, 1)[0]
    return float(10 ** slope)


MARKERS = {"RK23": "v", "RK45": "o", "DOP853": "s", "Radau": "D", "BDF": "^", "LSODA": "P"}


def plot_work_precision(path, points, title: str, *, evaluations_label: str = "function evaluations",
                        setting_label: str = "rtol", vlines=()) -> None:
    """Error against wall time (left) and against evaluations (right, when counted), one
    line per method, the Pareto front dashed, defaults starred.
    ``vlines``: (seconds, label) of cost-only entries (e.g. extrapolated explicit runs)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    panels = [("seconds", "wall time [s]")]
    if any(p.evaluations > 0 for p in usable(points)):
        panels.append(("evaluations", evaluations_label))
    fig, axes = plt.subplots(1, len(panels), figsize=(6 * len(panels), 4.8), constrained_layout=True,
                             squeeze=False)
    axes = axes[0]
    methods = list(dict.fromkeys(p.method for p in points))
    for ax, (key, xlabel) in zip(axes, panels):
        for m in methods:
            pts = sorted(usable(p for p in points if p.method == m), key=lambda p: -p.setting)
            pts = [p for p in pts if getattr(p, key) > 0]
            if not pts:
                continue
            xs = [getattr(p, key) for p in pts]
            ax.loglog(xs, [p.error for p in pts], marker=MARKERS.get(m, "o"), ms=5, lw=1.2, label=m)
            for p in pts:
                if p.default:
                    ax.loglog(getattr(p, key), p.error, marker="*", ms=16, color="gold", mec="k", zorder=5)
        if key == "seconds":
            front = pareto_front(points)
            ax.loglog([p.seconds for p in front], [p.error for p in front], ls="--", color="0.3", lw=1,
                      label="Pareto front", zorder=0)
            for (x, label), ls in zip(vlines, (":", "-.", "--")):
                ax.axvline(x, color="tab:red", ls=ls, lw=1, label=label)
        ax.set_xlabel(xlabel)
        ax.set_ylabel("error")
        ax.grid(True, which="both", alpha=0.3)
    axes[0].legend(fontsize=7)
    fig.suptitle(f"{title}  (star: shipped default; points: {setting_label} from loose to tight)")
    fig.savefig(path, dpi=110)
    plt.close(fig)


def save_study(ctx, key: str, title: str, points, info: dict | None = None, **plot_kw) -> None:
    """``precision_<key>.json`` (the info and every point) into the context's data dir and
    the work-precision plot ``wp_<key>.png`` into its plot dir, where those are set."""
    info = info or {}
    ctx.save_json(f"precision_{key}.json", {"info": info, "points": [p.as_dict() for p in points]})
    path = ctx.plot_path(f"wp_{key}.png")
    if path is not None:
        plot_work_precision(path, points, title, vlines=info.get("vlines", ()), **plot_kw)
