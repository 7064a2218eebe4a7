"""The committed figures are what the code draws: every figure is regenerated (through the command line, into a
temporary folder) and compared byte for byte with ``figures/``, so ``python -m tissuefem figures`` and ``build``,
which rewrite ``figures/`` in place, leave a clean checkout clean. The README's figure table lists exactly the
figures there are, and chapter 10's virtual-node title counts what the chapter prints."""

import re
from pathlib import Path

import matplotlib

matplotlib.use("Agg")

import numpy as np
import pytest

from helpers import FIGURES_DIR, figure_drift
from tissuefem.workbook import cli, figures

README = Path(__file__).resolve().parents[2] / "README.md"


@pytest.fixture(scope="module")
def regenerated(tmp_path_factory):
    """Every figure, drawn once by ``python -m tissuefem figures --out DIR`` (about a minute)."""
    note = figures.matplotlib_note()
    if note is not None:
        pytest.skip(f"the committed figures' text is drawn by another matplotlib: {note}")
    out = tmp_path_factory.mktemp("figures")
    assert cli.main(["figures", "--out", str(out)]) == 0
    return out


def test_every_committed_figure_is_what_the_code_draws(regenerated):
    drift = figure_drift(regenerated, figures.FIGURES)
    assert not drift, "the committed figures are not what the code draws:\n  " + "\n  ".join(drift)


def test_figures_holds_exactly_the_figures_of_the_registry():
    stems = {p.stem for p in FIGURES_DIR.iterdir() if p.suffix in (".png", ".gif")}
    pngs = {p.stem for p in FIGURES_DIR.glob("*.png")}
    missing = sorted(set(figures.FIGURES) - pngs)
    stale = sorted(stems - set(figures.FIGURES))
    assert not missing, f"figures never committed: {missing} (python -m tissuefem figures --only {' '.join(missing)})"
    assert not stale, f"committed files of no figure in the registry (remove them): {stale}"


def readme_figure_table(text) -> list[str]:
    """The figure names of the README's table under ``### Figures``, in their order."""
    section = text.split("\n### Figures\n", 1)[1].split("\n#", 1)[0]
    return re.findall(r"^\| `(\w+)` \|", section, flags=re.M)


def test_the_readme_table_lists_every_figure_and_no_other():
    listed = readme_figure_table(README.read_text(encoding="utf-8"))
    assert len(listed) == len(set(listed)), "the README lists a figure twice"
    missing = [n for n in figures.FIGURES if n not in listed]
    unknown = [n for n in listed if n not in figures.FIGURES]
    assert not missing, f"figures the README's table does not list: {missing}"
    assert not unknown, f"the README's table lists figures that do not exist: {unknown}"
    assert listed == list(figures.FIGURES), "the README's table is not in the chapters' order (`python -m tissuefem list`)"


def test_the_table_parser_sees_a_missing_row():
    text = "x\n### Figures\n\n| figure | shows |\n|---|---|\n| `fig_a` | a |\n| `fig_b` | b |\n\n### Next\n| `fig_c` | c |\n"
    assert readme_figure_table(text) == ["fig_a", "fig_b"]


def test_a_changed_figure_is_named_with_the_command_that_updates_it(tmp_path):
    committed = next(FIGURES_DIR.glob("*.png"))
    (tmp_path / committed.name).write_bytes(committed.read_bytes() + b"x")
    drift = figure_drift(tmp_path, [committed.stem])
    assert drift[0] == f"figures/{committed.name} differs from what the code draws now"
    assert drift[-1].startswith(f"update: python -m tissuefem figures --only {committed.stem}")


def test_the_virtual_node_title_counts_what_chapter_10_prints():
    """Chapter 10 prints, for its stroke on the 16-triangle sheet, the copies holding part of a triangle and the
    one whole triangle at the tip; the figure's title counts the same copies (the tip is not one of them)."""
    from tissuefem import rectangle
    from tissuefem.surgery.element_cuts import cut_through
    from tissuefem.workbook.figures.cutting import cut_pieces
    from tissuefem.workbook.procedures import VIRTUAL_NODES_STROKE

    cut = cut_through(rectangle(2.0, 1.0, 4, 2), np.array(VIRTUAL_NODES_STROKE))
    touched = np.array(sorted(cut.regions))
    printed = int((cut.weights[touched] < 1).sum()), int((cut.weights[touched] == 1).sum())  # the chapter's cell
    assert cut_pieces(cut) == printed == (6, 1)
    title = figures.FIGURES["fig_ch10_virtual_nodes"]().axes[1].get_title()
    assert f"into {printed[0]} copies" in title and f"{printed[1]} whole triangle at the crack tip" in title


def test_labels_of_crowded_points_do_not_overlap():
    """The chapter 9 Pareto figure's labels: points closer than a label's width get labels that overlap neither
    each other nor the points, and stay inside the axes."""
    from matplotlib.figure import Figure
    from matplotlib.text import Text

    from tissuefem.workbook.figures.tradeoffs import place_labels

    fig = Figure(figsize=(4.0, 3.0))
    ax = fig.subplots()
    x = np.array([10.0, 10.5, 11.0, 11.5, 30.0, 31.0])
    y = np.full_like(x, 0.09)
    ax.loglog(x, y, "o")
    ax.set(xlim=(1, 300), ylim=(0.03, 0.1))
    drawn = place_labels(ax, [(a, b, f"label {k}", "k") for k, (a, b) in enumerate(zip(x, y))], list(zip(x, y)))
    fig.draw_without_rendering()
    boxes = [Text.get_window_extent(t) for t in drawn]  # the words, without the leader line
    frame = ax.get_window_extent()
    for i, a in enumerate(boxes):
        assert frame.x0 <= a.x0 and a.x1 <= frame.x1 and frame.y0 <= a.y0 and a.y1 <= frame.y1
        for b in boxes[i + 1:]:
            assert not a.overlaps(b), (a, b)
