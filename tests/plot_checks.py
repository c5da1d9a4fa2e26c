"""What every plot of the suite must give its reader, checked on the matplotlib figure:
units on every axis, tick labels that do not overlap, a legend entry for every named mark.

:func:`assert_readable` is used by the tests of each plotting module (simulate, sweeps,
form-finding, stiffness, workspace, bags)."""

from __future__ import annotations

import re

#: An axis label with a unit: ``t [s]``, ``force [N]``, ``k [1] (dimensionless)``.
UNIT = re.compile(r"\[[^\]]+\]")


def assert_readable(fig, *, unitless: tuple[str, ...] = ()) -> None:
    """Every axes that draws something has x and y (and z) labels with a unit in brackets
    (the x label may be on the bottom axes of a shared column, an axis without ticks needs
    none, ``unitless`` lists labels that are categories); its tick labels do not overlap;
    every line, collection or patch group given a label is named in a legend of the figure."""
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    drawn = [ax for ax in fig.axes if ax.lines or ax.collections or ax.images or ax.patches]
    assert drawn, "the figure draws nothing"
    xlabels = [ax.get_xlabel() for ax in fig.axes if ax.get_xlabel()]
    for ax in drawn:
        ylabel, xlabel = ax.get_ylabel(), ax.get_xlabel()
        name = ax.get_title() or ylabel
        if not _is_colorbar(ax) and len(ax.get_yticks()):       # (an axis seen edge on has no ticks)
            assert ylabel and (UNIT.search(ylabel) or ylabel in unitless), f"{name!r}: y label {ylabel!r} has no unit"
            assert (xlabel and (UNIT.search(xlabel) or xlabel in unitless)) or \
                any(UNIT.search(x) for x in xlabels), f"{name!r}: no x label with a unit in its column"
        if ax.name == "3d" and len(ax.get_zticks()):
            assert UNIT.search(ax.get_zlabel()), f"{name!r}: z label {ax.get_zlabel()!r} has no unit"
        for axis in (ax.xaxis, ax.yaxis):
            _assert_no_overlap([t for t in axis.get_ticklabels() if t.get_visible() and t.get_text()],
                               renderer, name)
    named = {text.get_text() for ax in fig.axes for legend in [ax.get_legend(), *fig.legends]
             if legend is not None for text in legend.get_texts()}
    for ax in drawn:
        for artist in [*ax.lines, *ax.collections, *ax.containers]:
            label = artist.get_label()
            if label and not label.startswith("_"):
                assert label in named, f"{ax.get_title()!r}: {label!r} is drawn but in no legend"


def _is_colorbar(ax) -> bool:
    return ax.get_label() == "<colorbar>"


def _assert_no_overlap(labels, renderer, where: str) -> None:
    boxes = [(t.get_text(), t.get_window_extent(renderer)) for t in labels]
    for i, (a, box_a) in enumerate(boxes):
        for b, box_b in boxes[i + 1:]:
            assert not box_a.overlaps(box_b), f"{where!r}: tick labels {a!r} and {b!r} overlap"
