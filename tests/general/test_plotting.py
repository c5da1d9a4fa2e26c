"""The picture of a form-finding (``tensegrity formfind --plot``): units on the three axes,
tick labels apart, and a legend entry for every kind of thing drawn."""

from __future__ import annotations

import matplotlib
import pytest

from tensegrity_core.general import form_find, load_example
from tensegrity_core.general.plotting import plot_shapes
from tests.plot_checks import assert_readable

matplotlib.use("Agg")


@pytest.mark.parametrize("name, entries", [
    ("tensegrity_table", {"string", "rigid body", "initial shape (faint, dashed)"}),
    ("spine_c", {"string", "rigid body", "fixed node", "initial shape (faint, dashed)"}),
    ("t_bar", {"string", "bar"}),
])
def test_every_kind_of_member_and_marker_is_in_the_legend(name, entries):
    import matplotlib.pyplot as plt

    structure = load_example(name)
    result = form_find(structure)
    fig = plot_shapes(structure, result.nodes, structure.nodes)
    try:
        assert_readable(fig)
        legend = {t.get_text() for t in fig.axes[0].get_legend().get_texts()}
        assert entries <= legend, legend
    finally:
        plt.close(fig)
