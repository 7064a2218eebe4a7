"""Every figure a chapter draws is shown: a ``fig_*(...)`` call is the last expression of its cell (Jupyter
displays that value) or is passed to ``display(...)``. A figure drawn in the middle of a cell is closed and
returned, and the text around it then describes a picture that the executed chapter and the book never show.

The static check reads the committed notebooks (fast); ``missing_figures`` checks an executed chapter:
``test_notebooks.py`` applies it to every chapter it executes, and the book warns about a chapter it shows.
"""

import json
from pathlib import Path

import pytest

from tissuefem.workbook.notebooks import figure_calls, missing_figures

CHAPTERS = Path(__file__).resolve().parents[2] / "chapters"
CHAPTER_PATHS = sorted(CHAPTERS.glob("ch*.ipynb"))


@pytest.mark.parametrize("path", CHAPTER_PATHS, ids=[p.stem for p in CHAPTER_PATHS])
def test_every_figure_a_chapter_draws_is_shown(path):
    nb = json.loads(path.read_text(encoding="utf-8"))
    hidden = [f"cell {i}: {name}(...) is neither the cell's last expression nor passed to display()"
              for i, cell in enumerate(nb["cells"]) if cell["cell_type"] == "code"
              for name, shown in figure_calls(cell) if not shown]
    assert not hidden, f"{path.name} draws figures it never shows:\n  " + "\n  ".join(hidden)


def test_the_check_sees_a_hidden_figure_and_an_executed_one():
    cell = {"cell_type": "code", "source": "%matplotlib inline\nfig_a()\ndisplay(fig_b(x=1))\nprint(1)"}
    assert sorted(figure_calls(cell)) == [("fig_a", False), ("fig_b", True)]
    executed = {"cells": [dict(cell, outputs=[{"output_type": "display_data", "data": {"image/png": "..."}}])]}
    assert missing_figures(executed) == ["cell 0: fig_a, fig_b drew 2 figure(s) but shows 1 image(s)"]


def test_the_book_warns_about_a_figure_its_page_does_not_show(tmp_path):
    import nbformat

    from tissuefem.workbook.book import build_book

    (tmp_path / "chapters").mkdir()
    (tmp_path / "README.md").write_text("# x\n\nIntro.\n\n## Errata to the lecture notes\n\nNone.\n")
    nb = nbformat.v4.new_notebook()
    nb.cells = [nbformat.v4.new_markdown_cell("# Chapter 1 — x\n\n*Time: about 5 min.*"),
                nbformat.v4.new_code_cell("fig_a()\nx = 1")]
    nbformat.write(nb, tmp_path / "chapters" / "ch01_x.ipynb")
    nb.cells[1].outputs = []  # executed: the figure was drawn and dropped
    (tmp_path / "build").mkdir()
    nbformat.write(nb, tmp_path / "build" / "ch01_x.ipynb")
    messages = []
    build_book(tmp_path / "chapters", tmp_path / "build", tmp_path / "book", progress=messages.append)
    assert any("warning" in m and "fig_a" in m and "chapters/ch01_x.html" in m for m in messages), messages
