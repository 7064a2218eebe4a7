"""Grading support for the exercises: the same test grades the library and the student.

``TISSUEFEM_GRADE`` selects what is graded:

* ``all`` (default): the library's reference answer and the student's file;
* ``student``: only the student's file (``python -m tissuefem grade``);
* ``instructor``: only the student's file, and a function that imports, runs or uses the
  library (the reference implementation) is refused, once, while the stubs beside it stay
  "not attempted" (``python -m tissuefem grade --instructor``);
* ``library``: only the reference answer.

``TISSUEFEM_EXERCISES`` names another folder of ``chNN.py`` files to grade (a
student's submission); by default ``chapters/exercises``.

A failed comparison raises :class:`WrongAnswer`, which carries the expected and
the obtained values and a hint from :func:`diagnose` (a sign, a factor 2 or 1/2,
a transpose, a missing term); in the student and instructor modes ``conftest.py``
prints one line per failed check from it.
"""

from __future__ import annotations

import __future__
import ast
import importlib.util
import math
import os
import sys
import threading
from fractions import Fraction
from pathlib import Path

import numpy as np
import pytest

import tissuefem

DEFAULT_EXERCISES_DIR = Path(__file__).resolve().parents[1] / "chapters" / "exercises"
EXERCISES_DIR = Path(os.environ.get("TISSUEFEM_EXERCISES") or DEFAULT_EXERCISES_DIR).resolve()
MODES = ("all", "student", "instructor", "library")
MODE = os.environ.get("TISSUEFEM_GRADE", "all").strip().lower() or "all"
if MODE not in MODES:
    raise ValueError(f"TISSUEFEM_GRADE must be one of {MODES}, got {MODE!r}")
#: the modes that grade only the student's file (and print the summary table)
STUDENT_MODES = ("student", "instructor")

_modules = {}
#: instructor mode, per chapter: (a refusal of the whole file or None, {name: refusal})
_refusals = {}
#: instructor mode: the functions already refused, {(chapter, name): message}
_refused = {}


# --- wrong answers and their diagnosis ------------------------------------------------------------

class WrongAnswer(AssertionError):
    """A comparison that failed: what was checked, both values, and the likely slip."""

    def __init__(self, message, what, expected, got, hint):
        super().__init__(message)
        self.what, self.expected, self.got, self.hint = what, expected, got, hint


class Refused(AssertionError):
    """Instructor mode: the answer imports or runs the library instead of computing the result."""


def _transposes(a):
    """The transposes a student may have returned instead of ``a``, by name."""
    out = []
    if a.ndim >= 2 and a.shape[0] == a.shape[1]:
        # scikit-fem's layout [i, j, elements, points]: the tensor indices come first
        out.append(np.swapaxes(a, 0, 1))
    if a.ndim >= 2 and a.shape[-1] == a.shape[-2] and a.ndim != 2:
        out.append(np.swapaxes(a, -1, -2))
    if a.ndim == 4 and a.shape[0] == a.shape[1] and a.shape[2] == a.shape[3]:
        out.append(a.transpose(1, 0, 3, 2))  # both index pairs of a tangent dP_ij/dF_mn
    return out


def _nice_fraction(r):
    """``r`` as a small fraction such as 3/2, or None."""
    if not math.isfinite(r) or r == 0:
        return None
    f = Fraction(r).limit_denominator(8)
    if abs(f.numerator) <= 8 and math.isclose(float(f), r, rel_tol=1e-6):
        return f
    return None


def _factor_text(f):
    return {Fraction(1, 2): "½", Fraction(-1, 2): "−½", Fraction(1, 4): "¼"}.get(f, str(f).replace("-", "−"))


def diagnose(got, expected, *, terms=None, slips=None, rtol=1e-8, atol=1e-10):
    """Name the likely mistake that turns ``expected`` into ``got``, or say what was ruled out.

    Checks, in order: the test's own named wrong answers ``slips`` ({hint: wrong value});
    NaN or infinity; the whole result with the wrong sign, off by a factor 2, ½ or 4, or
    transposed; with ``terms`` ({name: value}, the additive terms whose sum is the
    expected value) one term missing, with the wrong sign, doubled, halved or transposed;
    any other constant factor; the right magnitudes with some signs wrong. Returns a
    short hint (one line).
    """
    got = np.asarray(got, dtype=float)
    expected = np.asarray(expected, dtype=float)
    rtol_d, atol_d = max(rtol, 1e-7), atol

    def matches(candidate):
        candidate = np.asarray(candidate, dtype=float)
        return candidate.shape == got.shape and bool(np.allclose(got, candidate, rtol=rtol_d, atol=atol_d))

    for hint, wrong in (slips or {}).items():
        if matches(wrong) and not np.allclose(wrong, expected, rtol=rtol_d, atol=atol_d):
            return hint
    if got.shape != expected.shape:
        if got.ndim == 2 and got.shape == expected.shape[::-1]:
            return f"shape {got.shape} is the transpose of the expected {expected.shape}: rows and columns swapped"
        if got.ndim == 0 and expected.ndim > 0:
            return f"expected an array of shape {expected.shape}, got one number: work on the whole array"
        if got.size == expected.size:
            return f"the right number of values in the wrong shape: expected {expected.shape}, got {got.shape}"
        return f"expected shape {expected.shape}, got {got.shape}: a missing or extra row/node, or another layout"
    if not np.all(np.isfinite(got)):
        bad = np.argwhere(~np.isfinite(got))
        where = f" at index {tuple(int(i) for i in bad[0])}" if got.ndim else ""
        return (f"NaN or infinity{where}: a log or a square root of a non-positive number, "
                "or a division by zero")
    if not np.any(np.abs(expected) > atol_d):
        return "expected zero here: some term of yours does not vanish in this case"
    if matches(-expected):
        return "sign slip: your result is −(expected value); look for a flipped minus sign"
    for factor, text in ((2.0, "2×"), (0.5, "½×"), (-2.0, "−2×"), (-0.5, "−½×"), (4.0, "4×"), (0.25, "¼×")):
        if matches(factor * expected):
            return f"factor slip: {text} the expected value (a ½ or a 2 lost or added, e.g. from d(x²)/dx = 2x)"
    for t in _transposes(expected):
        if not np.allclose(t, expected) and matches(t):
            return "transpose slip: you return the transpose (index convention F[i, j] = ∂φ_i/∂X_j)"
    for name, term in (terms or {}).items():
        term = np.broadcast_to(np.asarray(term, dtype=float), expected.shape)
        if not np.any(np.abs(term) > atol_d):
            continue  # a term that vanishes here cannot be told apart
        if matches(expected - term):
            return f"missing term: {name}"
        if matches(expected - 2 * term):
            return f"sign slip in the term {name}"
        if matches(expected + term):
            return f"factor slip: the term {name} is counted twice (2×)"
        if matches(expected - 0.5 * term):
            return f"factor slip: the term {name} is halved (½×)"
        for t in _transposes(term):
            if not np.allclose(t, term) and matches(expected - term + t):
                return f"transpose slip in the term {name}"
    nonzero = np.abs(expected) > atol_d
    ratios = got[nonzero] / expected[nonzero]
    r = float(ratios.flat[0])
    if np.allclose(ratios, r, rtol=rtol_d) and np.allclose(got[~nonzero], 0.0, atol=atol_d):
        nice = _nice_fraction(r)
        text = _factor_text(nice) if nice is not None else f"{r:.6g}"
        return f"factor slip: {text} × the expected value (a missing or extra coefficient)"
    if np.allclose(np.abs(got), np.abs(expected), rtol=rtol_d, atol=atol_d):
        wrong = np.argwhere(~np.isclose(got, expected, rtol=rtol_d, atol=atol_d))
        where = ", ".join(str(tuple(int(i) for i in w)) for w in wrong[:4])
        return f"right magnitudes, wrong sign at {where}{' …' if len(wrong) > 4 else ''}"
    checked = "sign, factor 2 or ½, transpose" + (", one of the terms " + ", ".join(terms) if terms else "")
    if got.ndim:
        wrong = np.argwhere(~np.isclose(got, expected, rtol=rtol, atol=atol))
        if 0 < len(wrong) < got.size:
            first = tuple(int(i) for i in wrong[0])
            return f"{len(wrong)} of {got.size} values differ, the first at {first} (not a {checked} slip)"
    return f"not a common slip ({checked}): compare your formula with the chapter term by term"


def _compact(a):
    a = np.asarray(a, dtype=float)
    return np.array2string(a, precision=10) if a.size <= 64 else f"array of shape {a.shape}"


def assert_close(got, expected, what, rtol=1e-8, atol=1e-10, *, terms=None, slips=None):
    """Compare with a message that shows both values, where they differ most, and a hint.

    ``terms`` ({name: value}) are the additive terms of the expected value and ``slips``
    ({hint: wrong value}) the wrong answers the test knows; both only sharpen the hint
    (see :func:`diagnose`).
    """
    got_arr = np.asarray(got, dtype=float)
    exp_arr = np.asarray(expected, dtype=float)
    if got_arr.shape == exp_arr.shape and np.allclose(got_arr, exp_arr, rtol=rtol, atol=atol):
        return
    hint = diagnose(got_arr, exp_arr, terms=terms, slips=slips, rtol=rtol, atol=atol)
    if got_arr.shape != exp_arr.shape:
        message = (f"{what}: expected shape {exp_arr.shape}, got shape {got_arr.shape}\n"
                   f"expected: {_compact(exp_arr)}\ngot:      {_compact(got_arr)}\nhint: {hint}")
    else:
        with np.errstate(invalid="ignore"):
            err = np.abs(got_arr - exp_arr)
        err = np.where(np.isnan(err), np.inf, err)
        worst = np.unravel_index(np.argmax(err), err.shape) if err.ndim else ()
        message = (f"{what} is wrong.\nexpected: {_compact(exp_arr)}\n"
                   f"got:      {_compact(got_arr)}\n"
                   f"largest difference {float(err.max()):.3e} at index {worst}\nhint: {hint}")
    raise WrongAnswer(message, what, exp_arr, got_arr, hint)


# --- the student's file ---------------------------------------------------------------------------

def _student_path(chapter):
    return Path(EXERCISES_DIR) / f"{chapter}.py"


def _student_module(chapter):
    if chapter not in _modules:
        path = _student_path(chapter)
        if not path.exists() and Path(EXERCISES_DIR) != DEFAULT_EXERCISES_DIR:
            pytest.skip(f"{path.name} is not in {EXERCISES_DIR} (nothing handed in for {chapter})")
        spec = importlib.util.spec_from_file_location(f"student_{chapter}", path)
        module = importlib.util.module_from_spec(spec)
        if MODE == "instructor":
            _refusals[chapter] = _load_watched(module, path)
        else:
            spec.loader.exec_module(module)  # a syntax error in the student's file fails loudly here
        _modules[chapter] = module
    return _modules[chapter]


class StudentAnswer:
    """The student's function ``chapter.name``; skips the test while it is still a stub.

    In instructor mode a function that imports or runs the library is refused by its first
    check; its other checks are skipped as refused, and the stubs beside it stay "not attempted".
    """

    def __init__(self, chapter, name):
        self.chapter, self.name = chapter, name

    def __repr__(self):
        return f"StudentAnswer({self.chapter}.{self.name})"

    def __call__(self, *args, **kwargs):
        module = _student_module(self.chapter)
        if MODE == "instructor":
            return self._call_watched(module, *args, **kwargs)
        func = getattr(module, self.name)
        try:
            return func(*args, **kwargs)
        except NotImplementedError:
            pytest.skip(f"{self.chapter}.{self.name} not attempted yet (the stub raises NotImplementedError)")

    def _refuse(self, message):
        key = (self.chapter, self.name)
        if key in _refused:
            pytest.skip(f"{self.chapter}.{self.name} refused by an earlier check")
        _refused[key] = message
        raise Refused(message)

    def _call_watched(self, module, *args, **kwargs):
        whole, reasons = _refusals[self.chapter]
        if whole or self.name in reasons:
            self._refuse(f"REFUSED: {whole or reasons[self.name]}")
        try:
            result, calls, tampered = _watched(getattr(module, self.name), *args, **kwargs)
        except _Raised as raised:
            calls, tampered, error = raised.calls, raised.tampered, raised.error
            if not calls and not tampered:
                if isinstance(error, NotImplementedError):
                    pytest.skip(f"{self.chapter}.{self.name} not attempted yet")
                raise error from None
        if tampered:
            self._refuse(f"REFUSED: {self.chapter}.{self.name} switched off the grader's watch (sys.setprofile)")
        if calls:
            self._refuse(f"REFUSED: {self.chapter}.{self.name} runs the library's code when called "
                         f"({calls[0]}): compute the answer yourself")
        return result


def implementations(chapter, name, reference):
    """pytest parameters: the library's reference function and/or the student's answer."""
    params = []
    if MODE in ("all", "library"):
        params.append(pytest.param(reference, id=f"library-{chapter}.{name}"))
    if MODE in ("all", *STUDENT_MODES):
        params.append(pytest.param(StudentAnswer(chapter, name), id=f"student-{chapter}.{name}"))
    return params


# --- instructor mode: an answer must not use the library ------------------------------------------

LIBRARY = "tissuefem"
_LIBRARY_DIRS = tuple({str(Path(tissuefem.__file__).parent) + os.sep,
                       str(Path(tissuefem.__file__).resolve().parent) + os.sep})
_IMPORTERS = {"__import__", "import_module", "find_spec", "spec_from_file_location", "run_module",
              "run_path", "load_module", "SourceFileLoader"}
_CODE_FROM_TEXT = {"exec", "eval", "compile"}
_FRAME_PEEKS = {"_getframe", "currentframe", "stack", "f_globals", "f_locals", "f_back", "get_objects"}


def _names_library(text):
    return isinstance(text, str) and LIBRARY in text


def _docstring_nodes(tree):
    nodes = set()
    for node in ast.walk(tree):
        if isinstance(node, (ast.Module, ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
            body = node.body
            if body and isinstance(body[0], ast.Expr) and isinstance(body[0].value, ast.Constant):
                nodes.add(id(body[0].value))
    return nodes


def _findings(tree, lines):
    """``[(line, message)]``: where the syntax tree imports or reaches for the library."""
    docstrings = _docstring_nodes(tree)
    found = []

    def report(node, why):
        if any(line == node.lineno for line, _ in found):
            return  # one finding per line is enough
        code = lines[node.lineno - 1].strip() if 0 < node.lineno <= len(lines) else ""
        found.append((node.lineno, f"line {node.lineno}: {why} ({code if len(code) <= 60 else code[:59] + '…'})"))

    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            if any(a.name == LIBRARY or a.name.startswith(LIBRARY + ".") for a in node.names):
                report(node, f"imports {LIBRARY}")
        elif isinstance(node, ast.ImportFrom):
            if node.module and (node.module == LIBRARY or node.module.startswith(LIBRARY + ".")):
                report(node, f"imports from {LIBRARY}")
            elif node.level:
                report(node, "a relative import (a file of exercises is not part of a package)")
        elif isinstance(node, ast.Call):
            func = node.func
            name = func.id if isinstance(func, ast.Name) else func.attr if isinstance(func, ast.Attribute) else ""
            if name in _IMPORTERS:
                first = node.args[0] if node.args else None
                if isinstance(first, ast.Constant) and isinstance(first.value, str):
                    if _names_library(first.value):
                        report(node, f"imports {LIBRARY} through {name}")
                else:
                    report(node, f"imports a module by a computed name through {name} (the grader cannot see which)")
            elif isinstance(func, ast.Name) and name in _CODE_FROM_TEXT:
                report(node, f"runs code from text with {name}() (the grader cannot see what it imports)")
            elif name == "_getframe":
                report(node, "looks at the caller's frames (the grader's own imports)")
        elif isinstance(node, ast.Attribute):
            if node.attr == "modules" and isinstance(node.value, ast.Name) and node.value.id == "sys":
                report(node, "reads sys.modules (reaches imported packages without importing them)")
            elif node.attr in _FRAME_PEEKS:
                report(node, "looks at the caller's frames or the interpreter's objects (the grader's own imports)")
        elif isinstance(node, ast.Constant) and id(node) not in docstrings and _names_library(node.value):
            report(node, f"names the {LIBRARY} package in a string")
    return sorted(found)


def library_use(source, filename="<answer>"):
    """Where ``source`` imports or reaches for the library, read from its syntax tree.

    Returns messages such as ``"line 3: imports tissuefem (from tissuefem.engine import
    materials1d)"``; empty when nothing is found. Catches import statements, importlib /
    ``__import__`` / runpy with the package's name or a computed name, ``sys.modules``,
    ``exec``/``eval``, a peek at the caller's frames, and any other string naming the package.
    What this cannot see (a name assembled at run time) the watch during the call catches.
    """
    return [message for _, message in _findings(ast.parse(source, filename), source.splitlines())]


def _bound_names(statement):
    """The module-level names a top-level statement binds, or None when it cannot be told
    (``from x import *``). Names local to the functions it defines are not counted."""
    names, stack = set(), [statement]
    while stack:
        node = stack.pop()
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
            names.add(node.name)
            stack.extend(node.decorator_list)
            continue
        if isinstance(node, (ast.Import, ast.ImportFrom)):
            for alias in node.names:
                if alias.name == "*":
                    return None
                names.add((alias.asname or alias.name).split(".")[0])
        elif isinstance(node, ast.Name) and isinstance(node.ctx, (ast.Store, ast.Del)):
            names.add(node.id)
        stack.extend(ast.iter_child_nodes(node))
    return names


def _used_names(statement):
    return {node.id for node in ast.walk(statement) if isinstance(node, ast.Name) and isinstance(node.ctx, ast.Load)}


def _load_watched(module, path):
    """Load the student's file statement by statement under the watch; say what is refused.

    Returns ``(whole, reasons)``: ``whole`` refuses the whole file (a top-level statement that
    reaches the library without binding a name a function could be blamed for), ``reasons``
    maps each module-level name that imports, runs or uses the library (directly, or through
    another such name: a helper, a module alias, a precomputed table) to its refusal. The
    other functions, stubs included, are graded as in the student mode.
    """
    source = path.read_text()
    tree = ast.parse(source, str(path))  # a syntax error in the student's file fails loudly here
    found = _findings(tree, source.splitlines())
    whole, reasons, flags = None, {}, 0
    statements = []
    for statement in tree.body:
        bound = _bound_names(statement)
        own = [m for line, m in found if statement.lineno <= line <= statement.end_lineno]
        if isinstance(statement, ast.ImportFrom) and statement.module == "__future__":
            for alias in statement.names:
                flags |= getattr(__future__, alias.name).compiler_flag
        code = compile(ast.Module([statement], type_ignores=[]), str(path), "exec", flags=flags, dont_inherit=True)
        try:
            _, calls, _ = _watched(exec, code, module.__dict__)
        except _Raised as raised:
            if not raised.calls:
                raise raised.error from None
            calls = raised.calls
        if calls:
            own.append(f"line {statement.lineno}: runs the library's code when the file is loaded ({calls[0]})")
        if own and not bound:
            whole = whole or f"{path.name} {own[0]}"
        for name in bound or ():
            if own:
                reasons.setdefault(name, f"{path.name} {own[0]}")
        statements.append((bound, _used_names(statement)))
    changed = True
    while changed:  # a name that uses a refused name is refused too
        changed = False
        for bound, used in statements:
            via = sorted(used & reasons.keys())
            for name in (bound or set()) - reasons.keys() if via else ():
                reasons[name] = f"{reasons[via[0]]}, used by {name} through {via[0]}"
                changed = True
    if whole:
        whole = f"{whole}; use numpy, scipy and scikit-fem, not {LIBRARY}"
    return whole, {name: f"{message}; use numpy, scipy and scikit-fem, not {LIBRARY}"
                   for name, message in reasons.items()}


class _Raised(Exception):
    def __init__(self, error, calls, tampered):
        super().__init__(str(error))
        self.error, self.calls, self.tampered = error, calls, tampered


def _watched(func, *args, **kwargs):
    """Call ``func`` while a profile hook records every function of the library that runs.

    Returns ``(result, calls, tampered)``: ``calls`` lists the library functions that ran
    (as ``module.py:function``), ``tampered`` is True when the answer replaced the hook.
    An exception of ``func`` comes back as ``_Raised`` with the same record.
    """
    calls = []

    def hook(frame, event, arg):
        if event == "call" and len(calls) < 3:
            filename = frame.f_code.co_filename
            if filename.startswith(_LIBRARY_DIRS):
                short = filename.split(os.sep + LIBRARY + os.sep, 1)[-1]
                calls.append(f"{LIBRARY}/{short.replace(os.sep, '/')}:{frame.f_code.co_name}")

    previous = sys.getprofile()
    sys.setprofile(hook)
    threading.setprofile(hook)
    try:
        result = func(*args, **kwargs)
    except Exception as error:  # noqa: BLE001 - reported with the record of what ran
        tampered = sys.getprofile() is not hook
        sys.setprofile(previous)
        threading.setprofile(None)
        raise _Raised(error, calls, tampered) from error
    tampered = sys.getprofile() is not hook
    sys.setprofile(previous)
    threading.setprofile(None)
    return result, calls, tampered
