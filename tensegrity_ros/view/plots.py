"""Time plots beside the 3D view: the last ``window`` seconds of chosen series.

:class:`SeriesHistory` keeps each series of the frames (no GUI, tested alone);
:class:`PlotPanel` shows two uPlot charts in the page, each with a choice of the
topology's series groups (``"actuator forces [N]"``: f1 and f2 over time [s]).
"""

from __future__ import annotations

from collections import deque
from typing import Any, Final

import numpy as np

from tensegrity_ros.view.frame import Frame, Topology

#: Line colours of a chart's series, in order (matplotlib's tab10).
PALETTE: Final = ("#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b", "#e377c2", "#7f7f7f",
                  "#bcbd22", "#17becf")
#: Series a chart shows at most (a group of many members shows its first ones).
MAX_SERIES: Final = len(PALETTE)


class SeriesHistory:
    """The samples of every series of the frames within the last ``window`` s of simulation
    time; a frame earlier than the last one (a reset, a jump back on a timeline) starts afresh."""

    def __init__(self, window: float = 10.0, max_samples: int = 3000):
        self.window = float(window)
        self._t: deque[float] = deque(maxlen=max_samples)
        self._values: deque[dict[str, float]] = deque(maxlen=max_samples)

    def add(self, frame: Frame) -> None:
        if self._t and frame.t < self._t[-1]:
            self.clear()
        self._t.append(frame.t)
        self._values.append(frame.series)
        while self._t and self._t[0] < frame.t - self.window:
            self._t.popleft()
            self._values.popleft()

    def clear(self) -> None:
        self._t.clear()
        self._values.clear()

    def arrays(self, keys: tuple[str, ...]) -> tuple[np.ndarray, ...]:
        """Times [s] and one array per key (NaN where a frame lacks it)."""
        t = np.fromiter(self._t, dtype=float, count=len(self._t))
        return (t, *(np.array([v.get(k, np.nan) for v in self._values], dtype=float) for k in keys))


def axis_ranges(data: tuple[np.ndarray, ...]) -> tuple[tuple[float, float], tuple[float, float]]:
    """Ranges of a chart's axes: the times' [s], and the values' with 5 % margins (never of
    zero width; NaN ignored; (0, 1) without values)."""
    t, values = data[0], np.concatenate([np.zeros(0), *data[1:]])
    values = values[np.isfinite(values)]
    t0 = float(t[0]) if len(t) else 0.0
    t1 = max(float(t[-1]) if len(t) else 1.0, t0 + 1e-3)
    lo, hi = (float(values.min()), float(values.max())) if len(values) else (0.0, 1.0)
    pad = 0.05 * (hi - lo) if hi > lo else 0.05 * max(abs(hi), 1.0)
    return (t0, t1), (lo - pad, hi + pad)


class PlotPanel:
    """Two charts in a GUI folder, each showing one series group chosen in a drop-down."""

    def __init__(self, gui: Any, topology: Topology, history: SeriesHistory):
        from viser import uplot

        self._uplot = uplot
        self.gui = gui
        self.history = history
        self.groups = {title: keys[:MAX_SERIES] for title, keys in topology.series_groups}
        titles = list(self.groups)
        self.charts = []
        with gui.add_folder("Plots"):
            for k, default in enumerate(titles[:2] + titles[:1] * (2 - len(titles[:2]))):
                choice = gui.add_dropdown(f"plot {k + 1}", tuple(titles), initial_value=default)
                data = self.history.arrays(self.groups[default])
                chart = gui.add_uplot(data, self._series(default), title=default, axes=self._axes(default),
                                      aspect=1.6, scales=self._scales(data))
                choice.on_update(lambda _e, c=choice, h=chart: self._choose(h, c.value))
                self.charts.append((choice, chart))

    def _series(self, title: str) -> tuple[Any, ...]:
        keys = self.groups[title]
        return (self._uplot.Series(label="t [s]"),
                *(self._uplot.Series(label=k.partition(":")[2], stroke=PALETTE[i % len(PALETTE)], width=2)
                  for i, k in enumerate(keys)))

    def _axes(self, title: str) -> tuple[Any, ...]:
        return (self._uplot.Axis(label="simulation time t [s]"), self._uplot.Axis(label=title))

    def _choose(self, chart: Any, title: str) -> None:
        chart.data = data = self.history.arrays(self.groups[title])
        chart.scales = self._scales(data)
        chart.series = self._series(title)
        chart.axes = self._axes(title)
        chart.title = title

    def refresh(self) -> None:
        """Send the charts the history as it is now, with their axes' ranges: the page keeps
        the ranges a chart was first drawn with (one sample: a range of zero width) unless
        they are sent."""
        for choice, chart in self.charts:
            data = self.history.arrays(self.groups[choice.value])
            chart.data = data
            chart.scales = self._scales(data)

    def _scales(self, data: tuple[np.ndarray, ...]) -> dict[str, Any]:
        (t0, t1), (lo, hi) = axis_ranges(data)
        return {"x": self._uplot.Scale(time=False, auto=False, range=(t0, t1)),
                "y": self._uplot.Scale(auto=False, range=(lo, hi))}
