"""Every chapter executes headless; committed chapters carry no outputs and match their text twins."""

import json
from pathlib import Path

import pytest

from tissuefem.workbook.notebooks import chapter_paths, execute_notebook, missing_figures

CHAPTERS = Path(__file__).resolve().parents[2] / "chapters"
NOTEBOOKS = chapter_paths(CHAPTERS)


def test_there_are_chapters():
    assert len(NOTEBOOKS) >= 2


@pytest.mark.parametrize("path", NOTEBOOKS, ids=[p.stem for p in NOTEBOOKS])
def test_notebook_is_committed_without_outputs(path):
    nb = json.loads(path.read_text())
    for cell in nb["cells"]:
        if cell["cell_type"] == "code":
            assert not cell.get("outputs"), f"{path.name} has outputs: clear them before committing"
            assert cell.get("execution_count") is None, f"{path.name} has execution counts"


@pytest.mark.parametrize("path", NOTEBOOKS, ids=[p.stem for p in NOTEBOOKS])
def test_notebook_matches_its_text_twin(path):
    jupytext = pytest.importorskip("jupytext")
    twin = CHAPTERS / "text" / f"{path.stem}.py"
    assert twin.exists(), f"{twin.name} missing: run `jupytext --sync chapters/{path.name}`"
    a = [(c.cell_type, c.source.strip()) for c in jupytext.read(path).cells]
    b = [(c.cell_type, c.source.strip()) for c in jupytext.read(twin).cells]
    assert a == b, f"{path.name} and text/{twin.name} differ: run `jupytext --sync chapters/{path.name}`"


@pytest.mark.notebook
@pytest.mark.parametrize("path", NOTEBOOKS, ids=[p.stem for p in NOTEBOOKS])
def test_notebook_executes(path, tmp_path):
    nb = execute_notebook(path, tmp_path / path.name)
    missing = missing_figures(nb)
    assert not missing, f"{path.name} executed, but figures it draws are not shown:\n  " + "\n  ".join(missing)
