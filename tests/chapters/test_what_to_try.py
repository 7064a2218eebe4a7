"""Every code snippet of every chapter's "What to try" section runs as written.

A chapter's "What to try" section (from its ``## What to try`` heading to the next
``## `` heading) gives each suggestion a fenced ``python`` block that runs on its own in a
fresh notebook cell: it imports what it needs and runs in seconds (the student is then
asked to change a number and run it again). This test extracts every such block and runs
it in a fresh namespace, from the chapters' folder, with matplotlib drawing off screen.
Any other code a suggestion names (in backticks, with a call or an attribute) must appear
in one of the section's blocks, so no suggestion carries code that is never run.
"""

from __future__ import annotations

import re
from pathlib import Path

import matplotlib
import pytest

from tissuefem.workbook.notebooks import chapter_paths

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

CHAPTERS = Path(__file__).resolve().parents[2] / "chapters"
FENCE = re.compile(r"^```python\s*\n(.*?)^```\s*$", re.S | re.M)
INLINE = re.compile(r"`([^`\n]+)`")


def what_to_try(path: Path) -> str:
    """The text of the chapter's "What to try" section (Markdown cells only)."""
    import nbformat

    nb = nbformat.read(path, as_version=4)
    text = "\n\n".join(c.source for c in nb.cells if c.cell_type == "markdown")
    match = re.search(r"^## What to try\s*$(.*?)(?=^## |\Z)", text, re.S | re.M)
    return match.group(1) if match else ""


def snippets(path: Path) -> list[str]:
    return FENCE.findall(what_to_try(path))


CASES = [(p, i, code) for p in chapter_paths(CHAPTERS) for i, code in enumerate(snippets(p))]


def test_every_chapter_has_runnable_suggestions():
    for path in chapter_paths(CHAPTERS):
        section = what_to_try(path)
        assert section, f"{path.name} has no '## What to try' section"
        assert snippets(path), f"{path.name}: its 'What to try' section has no fenced python snippet"


@pytest.mark.parametrize("path", chapter_paths(CHAPTERS), ids=lambda p: p.stem)
def test_code_named_in_a_suggestion_is_in_a_snippet(path):
    """Inline code that calls or reaches into something (``f(...)``, ``a.b``) must be run by a snippet."""
    section = what_to_try(path)
    code = "\n".join(snippets(path))
    prose = FENCE.sub("", section)
    for span in INLINE.findall(prose):
        if "(" in span or re.search(r"[A-Za-z_]\.[A-Za-z_]", span):
            if span.startswith(("python -m", "pip ")) or span.endswith((".toml", ".png", ".gif", ".json", ".py")):
                continue  # a shell command or a file name, not Python
            assert span in code, f"{path.name}: `{span}` is named in 'What to try' but no snippet runs it"


@pytest.mark.parametrize("path, index, code", CASES, ids=[f"{p.stem}-{i + 1}" for p, i, _ in CASES])
def test_snippet_runs(path, index, code, monkeypatch):
    monkeypatch.chdir(path.parent)
    plt.switch_backend("Agg")  # another test may have left an interactive backend in this process
    namespace = {"__name__": f"what_to_try_{path.stem}_{index + 1}"}
    try:
        exec(compile(code, f"{path.name}: what to try, snippet {index + 1}", "exec"), namespace)
    finally:
        plt.close("all")
