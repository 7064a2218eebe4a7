"""Chapter 9's figures: registered, byte-identical across runs, and drawn from the recorded study."""

import pytest

from helpers import assert_figure_deterministic
from tissuefem.workbook import figures
from tissuefem.workbook.bench.accuracy_cost import recorded_results
from tissuefem.workbook.figures.tradeoffs import KNOB_STYLE, plot_pareto

CHAPTER_9 = ["fig_ch09_pareto", "fig_ch09_scaling", "fig_ch09_budget", "fig_ch09_verification"]


def test_the_chapter_9_figures_are_registered():
    assert set(CHAPTER_9) <= set(figures.FIGURES)


@pytest.mark.parametrize("name", CHAPTER_9)
def test_chapter_9_figure_is_deterministic(name, tmp_path):
    assert_figure_deterministic(name, tmp_path)


def test_the_pareto_plot_has_one_curve_per_knob_and_the_budget_line():
    results = recorded_results()
    fig = plot_pareto(results)
    for ax in fig.axes:
        labels = [line.get_label() for line in ax.get_lines()]
        benchmark_knobs = {r["knob"] for r in results["knobs"]}
        drawn = {k for k, (_, _, label) in KNOB_STYLE.items() if label in labels}
        assert drawn and drawn <= benchmark_knobs
        # the 33 ms budget: a vertical line at the recorded budget
        assert any(len(set(line.get_xdata())) == 1 and line.get_xdata()[0] == pytest.approx(1e3 / 30)
                   for line in ax.get_lines())
