"""The sentences that read a recorded table of a chapter, checked against that table.

A chapter that quotes a recorded run shows it as a Markdown table; the sentence beside it must say what the
table says. These tests read the committed chapter (no execution) and recompute the sentence's numbers.
"""

import json
import re
from pathlib import Path

CHAPTERS = Path(__file__).resolve().parents[2] / "chapters"


def markdown_tables(path: Path) -> list[list[dict]]:
    """Every Markdown table of a chapter: a list of rows, each ``{header: cell text}``."""
    nb = json.loads(path.read_text(encoding="utf-8"))
    tables = []
    for cell in nb["cells"]:
        if cell["cell_type"] != "markdown":
            continue
        tables += tables_in("".join(cell["source"]) if isinstance(cell["source"], list) else cell["source"])
    return tables


def tables_in(text: str) -> list[list[dict]]:
    """The Markdown tables of a text, each a list of rows ``{header: cell text}``."""
    tables = []
    for block in re.findall(r"(?:^\|.*\|[ \t]*\n?)+", text, re.M):
        lines = [ln.strip().strip("|") for ln in block.strip().splitlines()]
        header = [h.strip() for h in lines[0].split("|")]
        tables.append([dict(zip(header, (c.strip() for c in ln.split("|")))) for ln in lines[2:]])
    return tables


def number(cell: str) -> float:
    """The leading number of a table cell: ``"1 280"`` -> 1280, ``"57% (the rest ...)"`` -> 57."""
    return float(re.match(r"[\d \u2009]+(?:\.\d+)?", cell).group(0).replace(" ", "").replace("\u2009", ""))


def test_ch07_the_benchmark_reading_matches_its_table():
    """Chapter 7, section 5 prints its table and its reading from the shipped record
    (:func:`~tissuefem.workbook.bench.realtime.recorded_realtime`); the record says what the reading takes for
    granted: a converged frame's median fits the 33 ms budget up to 16k triangles and not at 32k, and the ex43
    way is slower at every size."""
    from tissuefem.workbook.bench.realtime import recorded_realtime

    text = (CHAPTERS / "text" / "ch07_time_stepping.py").read_text()
    assert "display(Markdown(recorded_realtime_table()))" in text
    rows = {r["triangles"]: r for r in recorded_realtime()[0]}
    assert all(r["fast_median_ms"] < 33 for n, r in rows.items() if n <= 16_000)
    assert rows[32_040]["fast_median_ms"] > 33
    assert all(r["ex43_median_ms"] > r["fast_median_ms"] for r in rows.values())


def test_ch09_knob_tables_are_the_books_appendix():
    """Chapter 9 keeps the reading of each knob and links to the book's appendix for the tables: the appendix
    holds one table per benchmark and knob, every setting of the recorded study once, the baseline marked; the
    chapter prints no knob table but the settings on the Pareto fronts."""
    from tissuefem.workbook.bench.accuracy_cost import recorded_results
    from tissuefem.workbook.book import APPENDIX_PAGE, appendix_cells

    text = (CHAPTERS / "text" / "ch09_accuracy_cost.py").read_text()
    assert f"](../{APPENDIX_PAGE})" in text
    code = [ln.strip() for ln in text.splitlines() if not ln.lstrip().startswith("#")]
    assert [ln for ln in code if ln.startswith("show(")] == ["show([sel[i] for i in front])"]
    knobs = recorded_results()["knobs"]
    tables = tables_in("\n\n".join(appendix_cells()))
    assert len(tables) == len({(r["benchmark"], r["knob"]) for r in knobs})
    rows = [row for table in tables for row in table]
    assert sorted((r["benchmark"], r["knob"], r["value"].removesuffix(" (baseline)")) for r in rows) == \
        sorted((r["benchmark"], r["knob"], str(r["value"])) for r in knobs)
    assert sum(r["value"].endswith("(baseline)") for r in rows) == sum(r["baseline"] for r in knobs)
    assert all(len({(r["benchmark"], r["knob"]) for r in table}) == 1 for table in tables)
