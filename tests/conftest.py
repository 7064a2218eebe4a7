"""pytest hooks for grading the exercises.

In the student and instructor modes (``python -m tissuefem grade``, i.e.
``TISSUEFEM_GRADE=student`` or ``instructor``) tracebacks are switched off and the
run ends with a short summary: one line per exercise, then one line per failed
check with the expected value, the obtained value and a hint naming the likely
slip (see ``grading.diagnose``). Other modes are left as they are.
"""

from __future__ import annotations

import re
import traceback
from pathlib import Path

import numpy as np
import pytest

import grading

ACTIVE = grading.MODE in grading.STUDENT_MODES
_outcomes: dict[tuple, list[str]] = {}
_rows: list[tuple] = []
_refused: set[tuple] = set()  # the exercises refused in instructor mode


@pytest.hookimpl(tryfirst=True)
def pytest_configure(config):
    if not ACTIVE:
        return
    if config.option.tbstyle == "auto":
        config.option.tbstyle = "no"  # the summary says what failed; --tb=short brings tracebacks back
    config.option.reportchars = ""  # no "short test summary": the grading summary replaces it


def _student_answer(item):
    callspec = getattr(item, "callspec", None)
    answer = callspec.params.get("answer") if callspec else None
    return answer if isinstance(answer, grading.StudentAnswer) else None


def _exercise(item, answer):
    """A sortable key and a label such as ``2.1 neo_hookean_stress_1d``."""
    m = re.match(r"test_ex(\d+)_(\d+)", getattr(item, "originalname", item.name))
    number = (int(m.group(1)), int(m.group(2))) if m else (99, 99)
    label = f"{number[0]}.{number[1]} {answer.name}" if m else f"{answer.chapter}.{answer.name}"
    return (number, answer.name, label)


def _number(v):
    return f"{v:.6g}"


def _params(item, what=""):
    parts = []
    for name, value in item.callspec.params.items():
        if name == "answer" or name in what:  # already said by the check's own description
            continue
        if isinstance(value, (int, float, np.floating, np.integer)):
            text = _number(value)
        elif isinstance(value, str):
            text = value
        elif isinstance(value, np.ndarray) and value.size > 4:
            text = f"array{value.shape}"
        else:
            text = repr(np.asarray(value).tolist()) if isinstance(value, np.ndarray) else repr(value)
        parts.append(f"{name}={text[:24]}")
    return ", ".join(parts)


def _values(expected, got):
    """The two values to show: the whole value if it is one number, else the worst entry."""
    if expected.shape != got.shape:
        return f"shape {expected.shape}", f"shape {got.shape}"
    if expected.size == 1:
        return _number(float(expected.flat[0])), _number(float(got.flat[0]))
    with np.errstate(invalid="ignore"):
        err = np.abs(got - expected)
    err = np.where(np.isnan(err), np.inf, err)
    idx = np.unravel_index(np.argmax(err), err.shape)
    where = "[" + ", ".join(str(int(i)) for i in idx) + "]"
    return f"{_number(expected[idx])} at {where}", f"{_number(got[idx])} at {where}"


def _where_in_student_file(error):
    """``ch02.py:17`` for the deepest frame of the traceback that is in the student's folder."""
    folder = str(Path(grading.EXERCISES_DIR))
    place = ""
    for frame in traceback.extract_tb(error.__traceback__):
        if frame.filename.startswith(folder):
            place = f"{Path(frame.filename).name}:{frame.lineno}"
    return place


CHECK_WIDTH = 46


def _check(text, params):
    """The check's description clipped so that its parameters stay visible."""
    if not params:
        return _clip(text, CHECK_WIDTH)
    return f"{_clip(text, max(CHECK_WIDTH - len(params) - 3, 12))} [{params}]"


def _row(item, label, error):
    description = getattr(item, "originalname", item.name)
    description = re.sub(r"^test_ex\d+_\d+_?", "", description).replace("_", " ")
    if isinstance(error, grading.WrongAnswer):
        params = _params(item, error.what)
        check = _check(error.what, params)
        expected, got = _values(np.asarray(error.expected), np.asarray(error.got))
        return (label, check, expected, got, error.hint)
    check = _check(description, _params(item))
    if isinstance(error, grading.Refused):
        return (label, check, "", "", str(error))
    if isinstance(error, AssertionError):
        first = (str(error).strip().splitlines() or ["an assertion failed"])[0]
        return (label, check, "", "", first)
    place = _where_in_student_file(error)
    message = (str(error).strip().splitlines() or [""])[0]
    return (label, check, "", "", f"your code raised {type(error).__name__}: {message}"
            + (f" (at {place})" if place else ""))


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_makereport(item, call):
    outcome = yield
    if not ACTIVE:
        return
    answer = _student_answer(item)
    if answer is None:
        return
    report = outcome.get_result()
    if report.when != "call" and not (report.failed or report.skipped):
        return
    key = _exercise(item, answer)
    _outcomes.setdefault(key, []).append(report.outcome)
    if report.failed and call.excinfo is not None:
        _rows.append(_row(item, key[2], call.excinfo.value))
        if isinstance(call.excinfo.value, grading.Refused):
            _refused.add(key)


def _refusal_rows(rows):
    """A refusal is of the whole function, not of one check: its row says how many checks it stops."""
    checks = {key[2]: len(results) for key, results in _outcomes.items()}
    return [(r[0], f"all {checks[r[0]]} checks", r[2], r[3], r[4]) if r[4].startswith("REFUSED") else r
            for r in rows]


def _clip(text, width):
    return text if len(text) <= width else text[:width - 1] + "…"


def pytest_terminal_summary(terminalreporter, exitstatus, config):
    if not ACTIVE or not _outcomes:
        return
    tr = terminalreporter
    mode = "instructor: answers that use tissuefem are refused" if grading.MODE == "instructor" else "student"
    tr.section(f"grading summary ({mode})", sep="=")
    tr.write_line(f"graded: {grading.EXERCISES_DIR}")
    untouched = []
    width = max(len(key[2]) for key in _outcomes)
    for key in sorted(_outcomes):
        results = _outcomes[key]
        if all(r == "skipped" for r in results):
            untouched.append(key[2].split()[0])
            continue
        failed, passed = results.count("failed"), results.count("passed")
        verdict = "all passed" if failed == 0 and passed == len(results) else f"{failed} failed"
        if key in _refused:
            verdict = "refused (uses tissuefem)"
        tr.write_line(f"  {key[2]:{width}s}  {passed}/{len(results)} checks passed  {verdict}",
                      red=failed > 0, green=failed == 0)
    if untouched:
        tr.write_line(f"  not attempted yet: {', '.join(untouched)}")
    rows = _refusal_rows(_rows)
    if rows:
        widths = [min(max(len(r[i]) for r in rows), cap) for i, cap in enumerate((28, CHECK_WIDTH + 30, 18, 18))]
        widths = [max(w, len(h)) for w, h in zip(widths, ("exercise", "check", "expected", "got"))]
        tr.write_line("")
        tr.write_line(f"failed checks ({len(_rows)}):")
        header = ("exercise", "check", "expected", "got", "hint")
        tr.write_line("  ".join(_clip(h, w).ljust(w) for h, w in zip(header[:4], widths)) + "  hint")
        for row in rows:
            cells = [_clip(c, w).ljust(w) for c, w in zip(row[:4], widths)]
            tr.write_line("  ".join(cells) + "  " + row[4])
        first = rows[0][0].split()[0].replace(".", "_")
        folder = "" if grading.EXERCISES_DIR == grading.DEFAULT_EXERCISES_DIR else \
            f"TISSUEFEM_EXERCISES={grading.EXERCISES_DIR} "
        tr.write_line(f"a check's full message: {folder}TISSUEFEM_GRADE={grading.MODE} python -m pytest "
                      f"tests/chapters/test_exercises*.py -k ex{first} --tb=short")


@pytest.fixture(scope="session", autouse=True)
def _examples_independent_of_the_modules_imported_before():
    """The same examples however the tests are ordered. Hypothesis mixes into its draws the literal constants of
    the project's modules already imported (found through ``sys.modules``), so a derandomised test drew other
    examples after tests that imported more of the package (the chapters' exercises, the workbook) than when run
    alone: a property file's tests passed or failed by the order of the tests (seen in
    tests/engine/test_hostile_engine.py). Here that pool is kept empty for the whole run (where this version of
    Hypothesis has it; elsewhere nothing is changed)."""
    try:
        from hypothesis.internal.conjecture import providers
        empty = providers.Constants()
        cache = providers.CONSTANTS_CACHE.cache
        providers._get_local_constants  # noqa: B018 -- present in this version
    except (ImportError, AttributeError):
        yield
        return
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(providers, "_get_local_constants", lambda: empty)
        cache.clear()
        yield
    cache.clear()
