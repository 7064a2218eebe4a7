"""Every figure a chapter draws is shown: a ``fig_*(...)`` call is the last expression of its cell (Jupyter
displays that value) or is passed to ``display(...)``. A figure drawn in the middle of a cell is closed and
returned, and the text around it then describes a picture that the executed chapter and the book never show.

The static check reads the committed notebooks (fast); :func:`missing_figures` checks an executed chapter,
and ``test_notebooks.py`` applies it to every chapter it executes.
"""

import ast
import json
from pathlib import Path

import pytest

CHAPTERS = Path(__file__).resolve().parents[2] / "chapters"
CHAPTER_PATHS = sorted(CHAPTERS.glob("ch*.ipynb"))


def _source(cell) -> str:
    text = "".join(cell["source"]) if isinstance(cell["source"], list) else cell["source"]
    # IPython magics and shell escapes are not Python
    return "\n".join("" if line.lstrip().startswith(("%", "!")) else line for line in text.splitlines())


def figure_calls(cell) -> list[tuple[str, bool]]:
    """``(name, shown)`` for each ``fig_*(...)`` call of a code cell."""
    tree = ast.parse(_source(cell))
    last = tree.body[-1] if tree.body else None
    displayed = {id(arg) for node in ast.walk(tree)
                 if isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id == "display"
                 for arg in node.args}
    calls = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id.startswith("fig_"):
            shown = (isinstance(last, ast.Expr) and last.value is node) or id(node) in displayed
            calls.append((node.func.id, shown))
    return calls


def missing_figures(nb) -> list[str]:
    """The figures an executed notebook's cells draw but do not show as an image (``nb``: a notebook dict)."""
    missing = []
    for i, cell in enumerate(nb["cells"]):
        if cell["cell_type"] != "code" or not figure_calls(cell):
            continue
        images = sum(1 for out in cell.get("outputs", []) if any(k.startswith("image/") for k in out.get("data", {})))
        if images < len(figure_calls(cell)):
            missing.append(f"cell {i}: {', '.join(n for n, _ in figure_calls(cell))} drew "
                           f"{len(figure_calls(cell))} figure(s) but shows {images} image(s)")
    return missing


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
