"""Every number a chapter's prose states is bound to something that checks it.

A reviewer keeps finding sentences that a chapter's own outputs contradict ("10-25x faster" beside a table of
21-28x). The cause is that nothing ties the prose to the run. This test reads the Markdown cells of every
committed chapter (no execution: it is fast) and fails on a number in the prose that is none of:

* **not a statement at all**: inside ``$math$``, a code span or a fenced block, a link target, a heading's or a
  list's own numbering, a reference to a chapter, section, figure, exercise, erratum or cited work;
* **produced by the run**: a sentence that reports a computed number is written by a code cell
  (``display(Markdown(f"..."))``), so it is not in a Markdown cell and cannot drift;
* **recomputed by a named test**: a test docstring anywhere under ``tests/`` quotes (between double quotes,
  ``...`` for an elision) a piece of the sentence that contains the number;
* **declared** in :data:`DECLARED` below: an input (E = 1000, a mesh size), a definition (a solver's cap, a
  tolerance), a citation of a published figure, a reference the automatic rules miss (a table's "section"
  column), a number of a recorded run quoted as data ("recorded ...", saying where and on which machine), or a
  number a named test checks in other words ("checked-by tests/<file>.py::<test>").

Numbers inside ``$math$`` are exempt wholesale: a computed number written as math (a residual history as a
chain of arrows) escapes this check, so write such a sentence from the run.

A declaration whose quote is no longer in its chapter fails too (it would otherwise hide the next drift), and
so does a "checked-by" naming a test that does not exist.
"""

from __future__ import annotations

import ast
import functools
import json
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
CHAPTERS = ROOT / "chapters"
TESTS = ROOT / "tests"

KINDS = ("input", "definition", "citation", "reference", "checked-by", "recorded")

#: (chapter stem, numbers as the prose writes them, kind, a short quote of the sentence containing them).
#: Several numbers of one quote are separated by " / "; ``kind`` is one of :data:`KINDS`; "checked-by" is
#: followed by ``tests/<file>.py::<test>``, "recorded" by where the recording lives (a recorded run of a named
#: machine, quoted as data).

DECLARED: list[tuple[str, str, str, str]] = [
    ("ch01_linear_1d", "1 / 0", "definition", "is 1 at the last node and 0 elsewhere"),
    ("ch01_linear_1d", "2 / 1 / 3", "checked-by tests/engine/test_oned.py::test_convergence_rates",
     "The observed rates are 2 and 1 for P1, and 3 and 2 for P2"),
    ("ch03_kinematics_linear_2d", "1 / 2 / 3", "definition", "of a triangle with vertices 1, 2, 3"),
    ("ch03_kinematics_linear_2d", "60", "input", "turn the wall by 60° about the edge's midpoint"),
    ("ch03_kinematics_linear_2d", "15", "input", "the Neo-Hookean solve turns the wall in 15° steps"),
    ("ch04_neo_hookean_2d", "30", "input", "a 30 % stretch and a shear"),
    ("ch05_fibers", "45", "input", "At 45° the strip shears between its clamps"),
    ("ch06a_inversion", "1", "definition", "1 everywhere for a one-to-one map"),
    ("ch06b_inversion_robust", "13 / 0.1 / 1.0 / 1.3", "input",
     "move the top edge down in 13 steps of 0.1, to flat (1.0) and past it (1.3)"),
    ("ch06b_inversion_robust", "1.3", "checked-by tests/chapters/test_prose_claims.py::"
     "test_ch06b_the_log_model_crush_stops_before_flat_and_recovers", "the Taylor and stable meshes at 1.3 contain"),
    ("ch06b_inversion_robust", "100", "definition", "must converge within 100 iterations"),
    ("ch06b_inversion_robust", "13 / 1.3", "input", "13 frames down to 1.3, then frames at 1.3 until one converges"),
    ("ch06b_inversion_robust", "0", "checked-by tests/chapters/test_chapter_claims.py::"
     "test_ch06b_the_crush_in_frames_folds_instead_of_inverting", "is 0 for every model past flat"),
    ("ch06b_inversion_robust", "0.5", "input", "steps capped at 0.5, at"),
    ("ch06b_inversion_robust", "0.5", "input", "line search, steps capped at 0.5);"),
    ("ch06b_inversion_robust", "400", "input", "at most 400 iterations"),
    ("ch06b_inversion_robust", "0", "reference", 'no red triangle at all (the column "J <= 0 there")'),
    ("ch06b_inversion_robust", "10", "input", "only survives the 10× stretch"),
    ("ch06b_inversion_robust", "hundred times", "definition", "about five hundred times stiffer than the shear term"),
    ("ch07_time_stepping", "20 / 1", "recorded on the 2-core reference machine",
     "a SuperLU factorization of the 8k-triangle matrix takes ~20 ms, a back-substitution with it ~1 ms"),
    ("ch07_time_stepping", "15", "definition", "When CG slows down (more than 15 iterations)"),
    ("ch07_time_stepping", "0.1", "definition", "so CG stops at 0.1% of the current residual"),
    ("ch07_time_stepping", "10 / 3.3 / 1 / 3.0 / 0.1 / 2.2", "recorded on the 2-core reference machine",
     "At 8k triangles a 10% cap cost 3.3 Newton steps per frame, 1% cost 3.0, 0.1% cost 2.2"),
    ("ch07_time_stepping", "1", "input", 'every look at the clock "costs" 1 ms and the budget is 1 ns'),
    ("ch07_time_stepping", "1 / 0", "reference", "(the 0 and 1 printed below)"),
    ("ch07_time_stepping", "1 / 2 / 3", "input", "caps the steps per frame at 1, 2 or 3 on the standard drag"),
    ("ch07_time_stepping", "40", "input", "from the fully converged simulation after 40 frames"),
    ("ch07_time_stepping", "0.3 / 1", "input", "(E = 1000, ν = 0.3, ρ₀ = 1,"),
    ("ch07_time_stepping", "2", "definition", "two rounds on the 2-core reference machine"),
    ("ch08a_virtual_surgery", "3", "reference", "a handle (a Dirichlet condition) | 3 |"),
    ("ch08a_virtual_surgery", "4", "reference", "a new term of the energy (a contact penalty) | 4 |"),
    ("ch08a_virtual_surgery", "5 / 6", "reference", "nodes are duplicated along the cut | 5, 6 |"),
    ("ch08a_virtual_surgery", "60", "input", "Drag the example's pull handle for 60 frames"),
    ("ch08a_virtual_surgery", "12", "input", "pulled up and out over 12 frames, then let go"),
    ("ch08a_virtual_surgery", "0.2", "input", "depth 0.2 in four frames"),
    ("ch08a_virtual_surgery", "15", "definition", "grid of the exercise (15 nodes)"),
    ("ch08b_virtual_surgery", "0 / 1", "definition", "for a tightness s from 0 to 1"),
    ("ch08b_virtual_surgery", "8 / 30", "input", "A small run here (1000 triangles, 8 frames each); the full one, at 8000 "
     "triangles and 30 frames"),
    ("ch08b_virtual_surgery", "8", "input", "and 8 frames are few"),
    ("ch08b_virtual_surgery", "1.00", "checked-by tests/chapters/test_chapter_claims.py::"
     "test_ch08_effects_table_newton_counts", "the two linear rows take exactly 1.00 Newton step per frame"),
    ("ch08b_virtual_surgery", "2.00 / 2.38", "checked-by tests/chapters/test_chapter_claims.py::"
     "test_ch08_effects_table_newton_counts", "(2.00 for the quasistatic base, 2.38 with inertia)"),
    ("ch08b_virtual_surgery", "0.00", "recorded by the earlier version of the table",
     "before it was counted, these rows read 0.00"),
    ("ch08b_virtual_surgery", "32", "input", "the view steps one frame every 32 ms"),
    ("ch08b_virtual_surgery", "15", "input", "drag it down and out over 15 frames and let go"),
    ("ch08b_virtual_surgery", "1", "definition", "the tool's force at 1 kHz from a reduced model of the last frame"),
    ("ch08b_virtual_surgery", "1 / 30 / 100", "citation",
     "haptic force loops run near 1 kHz while the deformation runs at 30 to 100 frames a second"),
    ("ch08b_virtual_surgery", "7 / 6,500", "citation",
     "rendered force feedback within 7 ms from a linear elastic model of 6,500 tetrahedra"),
    ("ch08b_virtual_surgery", "1", "definition", "with a thread updating the force at 1 kHz beside the frames"),
    ("ch08b_virtual_surgery", "2", "definition", "runs on the 2-core reference machine"),
    ("ch09_accuracy_cost", "8 000", "input", "P1 on about 8 000 triangles, Neo-Hookean"),
    ("ch09_accuracy_cost", "2 / 3", "reference", "even P2 converges at a rate below 2 there instead of 3 (chapter 4)"),
    ("ch09_accuracy_cost", "48 / 12", "citation", "length 48, depth 12, a parabolic shear load"),
    ("ch09_accuracy_cost", "four times", "definition", "with steps two and four times larger"),
    ("ch09_accuracy_cost", "500", "input", "the flap on 500 triangles, five frames"),
    ("ch09_accuracy_cost", "1", "definition", "Errors that agree to 1 % are treated as equal"),
    ("ch09_accuracy_cost", "500 / 32 000", "input", "from 500 to 32 000 triangles, P1 or P2"),
    ("ch09_accuracy_cost", "1.7", "checked-by tests/workbook/test_bench_accuracy_cost.py::test_the_recorded_study_supports_what_chapter_9_says", "by a factor of about 1.7 at twice the cost"),
    ("ch09_accuracy_cost", "2 / 3 / 4 / 6", "input", "quadrature of degree 2, 3, 4 and 6"),
    ("ch09_accuracy_cost", "1", "checked-by tests/workbook/test_bench_accuracy_cost.py::test_the_recorded_study_supports_what_chapter_9_says", "2, 3, 4 and 6 agree to 1 %"),
    ("ch09_accuracy_cost", "3", "definition", "fewer than 3 points would leave a P2 triangle"),
    ("ch09_accuracy_cost", "30", "input", "in its place at a 30 % stretch"),
    ("ch09_accuracy_cost", "1", "definition", "less than the 1 % the front treats as a tie"),
    ("ch09_accuracy_cost", "20", "checked-by tests/workbook/test_bench_accuracy_cost.py::test_the_recorded_study_supports_what_chapter_9_says", "leave 20 % more error"),
    ("ch09_accuracy_cost", "2", "recorded in the workbook's earlier recording of the study",
     "it showed an error 2 % lower than converging"),
    ("ch09_accuracy_cost", "500", "input", "the flap on 500 triangles for five frames"),
    ("ch09_accuracy_cost", "0.8", "checked-by tests/workbook/test_bench_accuracy_cost.py::test_why_a_capped_newton_seemed_more_accurate", "(cosine about 0.8)"),
    ("ch09_accuracy_cost", "0.1", "checked-by tests/workbook/test_bench_accuracy_cost.py::test_why_a_capped_newton_seemed_more_accurate", "(cosine about 0.1)"),
    ("ch09_accuracy_cost", "1", "definition", "near 1 a machine twice as fast allows twice the triangles"),
    ("ch09_accuracy_cost", "2 000", "input", "P1 on about 2 000 triangles, Neo-Hookean or stable"),
    ("ch09_accuracy_cost", "1", "definition", "errors that agree to 1 % counted as ties"),
    ("ch09_accuracy_cost", "2 000 / 1", "checked-by tests/workbook/test_bench_accuracy_cost.py::test_the_recorded_study_supports_what_chapter_9_says",
     "P2 on about 2 000 triangles, with any quadrature rule (their errors agree to 1 %)"),
    ("ch10_cutting_contact", "1 200 / 2 600", "input", "meshed with 1 200 and with 2 600 triangles"),
    ("ch10_cutting_contact", "0.1", "definition", "Slivers (a piece holding less than 0.1 % of its triangle)"),
    ("ch10_cutting_contact", "0.8", "definition", "and takes at most 0.8 of it, as IPC does"),
    ("ch10_cutting_contact", "20", "input", "or tightened in 20 smaller steps"),
    ("ch11_tissue_3d", "0", "reference", 'columns "J <= 0 there" and "centroids covered twice there"'),
]

# --- reading the prose ------------------------------------------------------------------------------------

_SPACE = "\u00a0\u2009\u202f"
#: a number as prose writes it: 3, 0.41, 1 200 (thin or plain space between thousands), 32,550, -1.4, 4 %, 21–28
NUMBER = re.compile(rf"(?<![\w.\-−/^])[-−]?\d{{1,3}}(?:[ {_SPACE},]\d{{3}})*(?:\.\d+)?(?![\w]|\.\d)")
#: spelled numbers that state a ratio ("ten times finer", "a thousand times stiffer"; not "twice", which mostly
#: counts an action: "integrating twice", "reached twice")
WORD_RATIO = re.compile(r"\b(?:(?:two|three|four|five|six|seven|eight|nine|ten|eleven|twelve|twenty|"
                        r"fifty|hundred|thousand|million)(?:[- ]fold| times))\b", re.I)

_REFERENCE_WORDS = (r"chapters?|ch\.|sections?|figures?|fig\.|exercises?|errat(?:um|a)|references?|refs?\.|"
                    r"parts?|eqs?\.|equations?|goals?|items?|pages?|cells?|sittings?|appendix")
#: "chapter 8a", "chapters 3 and 4", "§1, §2 and §4", "exercise 6.1", "Figure 1", "reference [3]"
REFERENCE = re.compile(rf"(?:\b(?:{_REFERENCE_WORDS})|§)\s*(?:\d+[a-z]?(?:\.\d+)*[a-z]?"
                       rf"(?:\s*(?:,|and|or|to|–|-)\s*§?\d+[a-z]?(?:\.\d+)*[a-z]?)*)", re.I)
EXEMPT_PATTERNS = [
    re.compile(r"```.*?```", re.S),                 # fenced code
    re.compile(r"<!--.*?-->", re.S),                # comments
    re.compile(r"\$\$.*?\$\$", re.S),               # display math
    re.compile(r"\$[^$\n]*\$"),                     # inline math
    re.compile(r"`[^`\n]*`"),                       # code spans
    re.compile(r"\]\([^)\s]*\)"),                   # link targets
    re.compile(r"\[\d+(?:[,–-]\s*\d+)*\]"),        # numbered citations [3]
    re.compile(r"^\s*#+\s*\d+[a-z]?(?:\.\d+)*\.?", re.M),  # a heading's own number
    re.compile(r"^\s*(?:\d+[.)]|[-*+])\s", re.M),   # list markers
    re.compile(r"\*\*\d+\.\d+\*\*"),                # exercise labels **6.1**
    REFERENCE,
    re.compile(r"\bch\d\d[a-z]?\w*"),              # file names ch07_..., fig_ch10_...
    re.compile(r"\b[A-Z][\w.]*(?:\s+et al\.)?,?\s*\(?(?:19|20)\d\d\)?"),  # author or venue with its year
    re.compile(r"\d+\s*[×x]\s*\d+(?:\s*[×x]\s*\d+)?"),  # sizes: a 64 × 32 grid, a 2×2 matrix (inputs)
    re.compile(r"Time:?\**\s*about\s+\d+\s*min"),  # the time a chapter states (the syllabus reads it)
    # suggestions and exercise lists: their numbers are inputs the reader is invited to change
    re.compile(r"^#+\s*(?:What to try|Exercises)\b.*?(?=^#+\s|\Z)", re.S | re.M),
    # the frame budget, a definition of the whole workbook: 33 ms, 30 frames per second, a frame time of 1/30 s
    re.compile(r"\b33\s*ms\b|\b30 frames (?:per|a) second\b|\b1/30(?:\s*s)?\b"),
    # the index convention: formulas count from 1, code from 0
    re.compile(r"\*\*(?:Index convention|Counting indices)[^*]*\*\*.*?(?=\n\s*\n|\Z)", re.S),
]


def normalize(text: str) -> str:
    """Compare quotes and sentences without Markdown emphasis, math dollars, odd spaces or case."""
    text = re.sub(rf"[*`$_{_SPACE}]", " ", text).replace("−", "-").replace("–", "-").replace("—", "-")
    return re.sub(r"\s+", " ", text).strip().casefold()


def number_key(number: str) -> str:
    """``"1 200"`` and ``"1200"``, ``"-1.4"`` and ``"−1.4"`` alike; a spelled ratio in lower case."""
    if not number[:1].isdigit() and number[:1] not in "-−":
        return number.casefold()
    return re.sub(rf"[ {_SPACE},]", "", number).replace("−", "-").lstrip("-")


def _squeeze(text: str) -> str:
    """Thousands written with a space or a comma (``12 000``, ``32,550``) as plain digits."""
    return re.sub(r"(?<=\d)[ ,](?=\d{3}(?!\d))", "", text)


def _blank(match) -> str:
    return re.sub(r"[^\n]", " ", match.group(0))


def sentences(markdown: str):
    """The sentences of a Markdown cell, each as ``(text, stated)``: ``stated`` is the text with everything exempt
    blanked out (same length, so positions agree)."""
    stated = markdown
    for pattern in EXEMPT_PATTERNS:
        stated = pattern.sub(_blank, stated)
    start = 0
    ends = [m.end() for m in re.finditer(r"(?<=[.!?:])\s+(?=[*_(\"“]*[A-Z§])|\n\s*\n|\n(?=\s*(?:[-*+]|\d+\.)\s)|"
                                         r"\n(?=\s*\|)|\|\s*\n", markdown)]
    for end in [*ends, len(markdown)]:
        if markdown[start:end].strip():
            yield markdown[start:end], stated[start:end]
        start = end


def stated_numbers(stated: str) -> list[str]:
    return [m.group(0).strip() for m in NUMBER.finditer(stated)] + [m.group(0) for m in WORD_RATIO.finditer(stated)]


def chapter_markdown(path: Path) -> list[str]:
    nb = json.loads(path.read_text(encoding="utf-8"))
    return ["".join(c["source"]) if isinstance(c["source"], list) else c["source"]
            for c in nb["cells"] if c["cell_type"] == "markdown"]


# --- what checks a number ---------------------------------------------------------------------------------

@functools.lru_cache(maxsize=1)
def test_docstrings() -> dict[str, str]:
    """``{"tests/x.py::test_y": docstring}`` of every test function under ``tests/``."""
    found = {}
    for path in sorted(TESTS.rglob("test_*.py")):
        tree = ast.parse(path.read_text(encoding="utf-8"))
        for node in ast.walk(tree):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)) and node.name.startswith("test"):
                doc = ast.get_docstring(node)
                if doc:
                    found[f"{path.relative_to(ROOT).as_posix()}::{node.name}"] = doc
    return found


test_docstrings.__test__ = False  # a helper, not a test


def quoted_pieces(docstring: str) -> list[str]:
    """The pieces a docstring quotes: text between double quotes, split at ``...`` elisions."""
    pieces = []
    # a quote runs to its closing mark, or to the end of the docstring when that is where it ends
    for quote in re.findall(r"[\"“]{1,2}(.+?)(?:[\"”]{1,2}(?=[\s,.;:)\-]|$)|\Z)", docstring, re.S):
        pieces += [p for p in map(normalize, re.split(r"\.\.\.|…", quote)) if len(p) >= 8]
    return pieces


def unbound_numbers(paths=None, declared=None, docstrings=None) -> list[str]:
    """One line per number of the prose that nothing binds: chapter, number and sentence."""
    declared = DECLARED if declared is None else declared
    docstrings = dict(test_docstrings()) if docstrings is None else docstrings
    pieces = [p for doc in docstrings.values() for p in quoted_pieces(doc)]
    problems = []
    for path in paths or sorted(CHAPTERS.glob("ch*.ipynb")):
        mine = [(number_key(n), normalize(q)) for stem, ns, _, q in declared if stem == path.stem
                for n in ns.split(" / ")]
        for cell in chapter_markdown(path):
            for text, stated in sentences(cell):
                numbers = stated_numbers(stated)
                if not numbers:
                    continue
                sentence = normalize(text)
                for number in numbers:
                    key = number_key(number)
                    if any(q in sentence for k, q in mine if k == key.casefold() or k == key):
                        continue
                    if any(p in sentence and re.search(rf"(?<![\d.]){re.escape(key)}(?![\d])", _squeeze(p))
                           for p in pieces):
                        continue
                    if not key[0].isdigit() and any(p in sentence and key.casefold() in p for p in pieces):
                        continue
                    problems.append(f"{path.stem}: {number!r} in \"{' '.join(text.split())[:200]}\"")
    return problems


#: Chapters whose prose still holds unbound numbers, each waiting for its sentences to be generated by the run,
#: quoted by a test or declared. The test of such a chapter is an expected failure, strict: once a chapter is
#: bound its entry must go, and no other chapter can join the list unnoticed.
PENDING: set[str] = set()

# --- the tests --------------------------------------------------------------------------------------------

CHAPTER_PATHS = sorted(CHAPTERS.glob("ch*.ipynb"))


@pytest.mark.parametrize("path", [pytest.param(p, marks=pytest.mark.xfail(
    strict=True, reason="numbers of this chapter's prose not yet bound")) if p.stem in PENDING else p
    for p in CHAPTER_PATHS], ids=[p.stem for p in CHAPTER_PATHS])
def test_every_number_of_the_prose_is_bound(path):
    problems = unbound_numbers([path])
    assert not problems, (
        f"{len(problems)} number(s) of {path.name}'s prose report something that nothing checks: write the "
        "sentence from the run (display(Markdown(f\"...\"))), quote it in the docstring of the test that "
        "recomputes it, or declare it in tests/chapters/test_prose_numbers.py::DECLARED (input, definition, "
        "citation, checked-by <test>):\n  " + "\n  ".join(problems))


def test_declarations_are_current():
    stems = {p.stem: p for p in CHAPTER_PATHS}
    docstrings = test_docstrings()
    stale = []
    for stem, numbers, kind, quote in DECLARED:
        head = kind.split()[0]
        if stem not in stems:
            stale.append(f"{stem}: no such chapter")
            continue
        number = numbers
        if head not in KINDS:
            stale.append(f"{stem} {number!r}: kind {kind!r} is none of {KINDS}")
        if head == "checked-by" and kind.split()[-1] not in docstrings and not _test_exists(kind.split()[-1]):
            stale.append(f"{stem} {number!r}: {kind.split()[-1]} does not exist")
        text = normalize(" ".join(chapter_markdown(stems[stem])))
        if normalize(quote) not in text:
            stale.append(f"{stem} {number!r}: the quote \"{quote}\" is no longer in the chapter")
        for number in numbers.split(" / "):
            key = number_key(number)
            if (key.replace(" ", "") if key[0].isdigit() else key) not in (
                    re.sub(r"[ ,]", "", normalize(quote)) if key[0].isdigit() else normalize(quote)):
                stale.append(f"{stem} {number!r}: the quote \"{quote}\" does not contain the number")
    assert not stale, "stale declarations in DECLARED:\n  " + "\n  ".join(stale)


def _test_exists(ref: str) -> bool:
    file, _, name = ref.partition("::")
    path = ROOT / file
    return path.exists() and re.search(rf"^\s*def {re.escape(name)}\b", path.read_text(), re.M) is not None


# --- the checker checks what it should ------------------------------------------------------------------------

def test_the_checker_catches_a_computed_number_and_exempts_the_rest(tmp_path):
    nb = {"cells": [{"cell_type": "markdown", "source": (
        "## 5. Costs\n\nAs chapter 4 showed (see §3 and exercise 6.1), $E = 1000$ and `n=8`.\n"
        "1. The solver is 10–25× faster here.\n\nThat is ten times finer.")}], "metadata": {}}
    path = tmp_path / "ch99_demo.ipynb"
    path.write_text(json.dumps(nb))
    found = unbound_numbers([path], declared=[], docstrings={})
    assert [line.split(":", 1)[1].split(" in ")[0].strip() for line in found] == ["'10'", "'25'", "'ten times'"]
    found = unbound_numbers([path], declared=[("ch99_demo", "10", "input", "10–25× faster")],
                            docstrings={"t::test_x": '"That is ten times finer".'})
    assert [line.split(":", 1)[1].split(" in ")[0].strip() for line in found] == ["'25'"]
