"""The plots of ``tensegrity sweep --plot``: every axis with its unit (varied quantities by
their key paths, results by their definitions), a boolean as its two categories, a legend
for every mark, legible ticks; in each of the three modes (line, heat map, histogram)."""

from __future__ import annotations

import matplotlib
import pytest

from tensegrity_core.sweep import load_sweep, run_sweep
from tensegrity_core.sweep.plotting import sweep_figure
from tensegrity_core.sweep.points import Quantity
from tensegrity_core.sweep.units import coordinate_unit, key_unit, quantity_label
from tests.plot_checks import assert_readable
from tests.sweep.conftest import fold_sweep, monte_carlo_sweep

matplotlib.use("Agg")


@pytest.mark.parametrize("path, class2, unit", [
    ("model.params.k", True, "N/m"), ("model.params.c3", True, "N s/m"), ("model.params.L", True, "m"),
    ("model.params.m", True, "kg"), ("inputs.f1.gain", True, "N/(m s)"), ("inputs.f2.to", True, "N"),
    ("inputs.act1.to", False, "m"), ("inputs.f2.t1", True, "s"), ("initial.equilibrium.rho1", True, "m"),
    ("initial.q[2]", True, "rad"), ("initial.qdot[0]", True, "m/s"), ("effects[damping].beta", False, "s"),
    ("effects[gravity].vector[2]", False, "m/s^2"), ("effects[loads].c1[2]", False, "N"),
    ("members[side*].rest_length", False, "m"), ("members[m0].EA", False, "N"), ("duration", True, "s"),
])
def test_a_key_paths_unit_comes_from_the_formats_documented_units(path, class2, unit):
    assert key_unit(path, class2=class2) == unit


@pytest.mark.parametrize("name, unit", [("rho1", "m"), ("beta", "rad"), ("beta_dot", "rad/s"), ("rho2_dot", "m/s"),
                                        ("x_top.cz", "m"), ("x_top.rx", "rad"), ("v_top.cx", "m/s"),
                                        ("v_top.rz", "rad/s"), ("x_t1.z", "m")])
def test_a_coordinates_unit_comes_from_its_name(name, unit):
    assert coordinate_unit(name) == unit


def test_quantities_are_named_in_words_with_their_unit():
    k = Quantity("model.params.k", "model.params.k", "values", (1.0, 2.0))
    side = Quantity("members[side*].rest_length", "side_factor", "grid", (0.6, 1.6), scale=True)
    gain = Quantity("inputs.f1.gain", "inputs.f1.gain", "values", (8.0, 12.0))
    assert quantity_label(k, class2=True) == "spring stiffness k [N/m]"
    assert quantity_label(side, class2=False) == "side_factor [1]"
    assert quantity_label(gain, class2=True) == "f1 gain [N/(m s)]"


def _check(sweep: dict, expected_labels: set[str]) -> None:
    import matplotlib.pyplot as plt

    table = run_sweep(sweep, workers=0, progress=False)
    fig = sweep_figure(table, load_sweep(sweep))
    try:
        bools = {ax.get_ylabel() for ax in fig.axes} | {ax.get_xlabel() for ax in fig.axes}
        assert_readable(fig, unitless=tuple(b for b in bools if b and "[" not in b))
        labels = {ax.get_xlabel() for ax in fig.axes} | {ax.get_ylabel() for ax in fig.axes}
        assert expected_labels <= labels, labels
    finally:
        plt.close(fig)


def test_a_line_over_one_quantity_has_units_on_both_axes():
    _check(fold_sweep(results=[{"first_event_time": {"kind": "fold"}}, {"event_count": {"kind": "fold"}}]),
           {"f1 gain [N/(m s)]", "first_fold_time [s]", "fold_count [count]"})


def test_a_heat_map_draws_a_boolean_as_two_categories():
    import matplotlib.pyplot as plt

    # stable at diagonal factor 0.9, not at 1.1 (18 slack members), at either side factor; a side
    # factor of 1.6 with 1.1 (35 slack) took the form-finding ~4 s of CPU, 1.3 takes ~0.2 s
    sweep = {"base": {"structure": "spine_c"},
             "vary": {"members[side*].rest_length": {"values": [0.6, 1.3], "scale": True, "name": "side_factor"},
                      "members[diag*].rest_length": {"values": [0.9, 1.1], "scale": True, "name": "diagonal_factor"}},
             "compute": "form_find", "results": ["stable", "slack_members", "max_member_force"]}
    _check(sweep, {"side_factor [1]", "diagonal_factor [1]", "slack_members [count]", "max_member_force [N]"})
    fig = sweep_figure(run_sweep(sweep, workers=0, progress=False), load_sweep(sweep))
    try:
        bar = next(ax for ax in fig.axes if ax.get_ylabel() == "stable")       # the colour bar of `stable`
        assert [t.get_text() for t in bar.get_yticklabels()] == ["false", "true"]
    finally:
        plt.close(fig)


def test_histograms_of_random_samples_have_units_and_a_legend_for_the_bars():
    _check(monte_carlo_sweep(samples=6), {"first_fold_time [s]", "points [count]"})
