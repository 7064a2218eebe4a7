"""Grading support for the exercises: the same test grades the library and the student.

``TISSUEFEM_GRADE`` selects what is graded: ``all`` (default: the library's
reference answer and the student's file), ``student`` (only the student's
file: ``python -m tissuefem grade``) or ``library``.
"""

from __future__ import annotations

import importlib.util
import os
from pathlib import Path

import numpy as np
import pytest

EXERCISES_DIR = Path(__file__).resolve().parents[1] / "chapters" / "exercises"
MODES = ("all", "student", "library")
MODE = os.environ.get("TISSUEFEM_GRADE", "all").strip().lower() or "all"
if MODE not in MODES:
    raise ValueError(f"TISSUEFEM_GRADE must be one of {MODES}, got {MODE!r}")

_modules = {}


def _student_module(chapter):
    if chapter not in _modules:
        path = EXERCISES_DIR / f"{chapter}.py"
        spec = importlib.util.spec_from_file_location(f"student_{chapter}", path)
        module = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(module)  # a syntax error in the student's file fails loudly here
        _modules[chapter] = module
    return _modules[chapter]


class StudentAnswer:
    """The student's function ``chapter.name``; skips the test while it is still a stub."""

    def __init__(self, chapter, name):
        self.chapter, self.name = chapter, name

    def __call__(self, *args, **kwargs):
        func = getattr(_student_module(self.chapter), self.name)
        try:
            return func(*args, **kwargs)
        except NotImplementedError:
            pytest.skip(f"{self.chapter}.{self.name} not attempted yet (the stub raises NotImplementedError)")


def implementations(chapter, name, reference):
    """pytest parameters: the library's reference function and/or the student's answer."""
    params = []
    if MODE in ("all", "library"):
        params.append(pytest.param(reference, id=f"library-{chapter}.{name}"))
    if MODE in ("all", "student"):
        params.append(pytest.param(StudentAnswer(chapter, name), id=f"student-{chapter}.{name}"))
    return params


def assert_close(got, expected, what, rtol=1e-8, atol=1e-10):
    """Compare with a message that shows both values (and where they differ most)."""
    got_arr = np.asarray(got, dtype=float)
    exp_arr = np.asarray(expected, dtype=float)
    if got_arr.shape != exp_arr.shape:
        raise AssertionError(f"{what}: expected shape {exp_arr.shape}, got shape {got_arr.shape}\n"
                             f"expected: {exp_arr}\ngot:      {got_arr}")
    if not np.allclose(got_arr, exp_arr, rtol=rtol, atol=atol):
        err = np.abs(got_arr - exp_arr)
        worst = np.unravel_index(np.argmax(err), err.shape) if err.ndim else ()
        raise AssertionError(
            f"{what} is wrong.\nexpected: {np.array2string(exp_arr, precision=10)}\n"
            f"got:      {np.array2string(got_arr, precision=10)}\n"
            f"largest difference {float(err.max()):.3e} at index {worst}"
        )
