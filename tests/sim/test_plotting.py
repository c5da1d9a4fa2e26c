"""The plot of a run (``tensegrity simulate --plot``): units on every axis, legible ticks, a
legend for every mark and for every kind of event, for the class-2 mechanism and for a
general structure (whose coordinates mix metres and radians, drawn on two axes)."""

from __future__ import annotations

import matplotlib

from tensegrity_core.sim import simulate
from tensegrity_core.sim.plotting import trajectory_figure
from tests.plot_checks import assert_readable

matplotlib.use("Agg")


def _legend_texts(fig) -> set[str]:
    return {t.get_text() for ax in fig.axes if ax.get_legend() for t in ax.get_legend().get_texts()}


def test_the_class2_plot_names_every_mark_and_unit_and_its_events():
    import matplotlib.pyplot as plt

    traj = simulate("paper_fold", duration=2.0)          # folds (1.38 s) and a release
    assert {"fold", "release"} <= {kind for _, kind, _ in traj.events}
    fig = trajectory_figure(traj)
    try:
        assert_readable(fig)
        assert {"event: fold", "event: release", "rho1", "rho2", "beta (right axis)"} <= _legend_texts(fig)
        labels = [ax.get_ylabel() for ax in fig.axes]
        assert "actuator length [m]" in labels and "beta [rad]" in labels    # metres and radians apart
    finally:
        plt.close(fig)


def test_a_general_structures_plot_keeps_metres_and_radians_apart_and_has_no_empty_panel():
    import matplotlib.pyplot as plt

    traj = simulate("spine_release", duration=0.05)     # 72 members, 9 bodies, no actuators
    fig = trajectory_figure(traj)
    try:
        assert_readable(fig)
        labels = [ax.get_ylabel() for ax in fig.axes]
        assert "speed [m/s]" in labels and "angular speed [rad/s]" in labels
        assert not any("actuator" in ax.get_title() for ax in fig.axes)       # no panel for no actuators
        members = next(ax for ax in fig.axes if ax.get_title().startswith("member forces"))
        colors = [tuple(line.get_color()) if not isinstance(line.get_color(), str) else line.get_color()
                  for line in members.lines]
        assert len(colors) == 12 and len(set(colors)) == 12                   # each its own colour
    finally:
        plt.close(fig)
