"""What a student and an instructor see: the diagnosis of a wrong answer, the short summary of
``python -m tissuefem grade``, and the instructor mode that refuses the library's own answer.

The end-to-end tests run the grade command in a subprocess on a folder of answer files
written here (the command's ``--exercises``), so the real chapters/exercises stay untouched.
"""

import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

import grading

ROOT = Path(__file__).resolve().parents[2]

# Chapter 2 with three slips: the sign of one stress term, a factor 2 on the tangent, and the
# Newton update solved with +q.
CH02_SLIPS = '''
import numpy as np


def neo_hookean_stress_1d(F, lam, mu):
    F = np.asarray(F, dtype=float)
    return mu * F + (lam * np.log(F) + mu) / F


def neo_hookean_tangent_1d(F, lam, mu):
    F = np.asarray(F, dtype=float)
    return 2 * (mu + (mu + lam * (1.0 - np.log(F))) / F**2)


def newton_step_1d(nodes, u, lam, mu, traction):
    n = nodes.size
    q, K = np.zeros(n), np.zeros((n, n))
    for e in range(n - 1):
        h = nodes[e + 1] - nodes[e]
        F = 1.0 + (u[e + 1] - u[e]) / h
        P = mu * F + (lam * np.log(F) - mu) / F
        dP = mu + (mu + lam * (1.0 - np.log(F))) / F**2
        q[e:e + 2] += P * np.array([-1.0, 1.0])
        K[e:e + 2, e:e + 2] += dP / h * np.array([[1.0, -1.0], [-1.0, 1.0]])
    q[-1] -= traction
    du = np.linalg.solve(K[1:, 1:], q[1:])
    return np.concatenate([[0.0], u[1:] + du])
'''

# Chapter 3: F of a triangle with rows and columns swapped (the notes' printed convention).
CH03_TRANSPOSE = '''
import numpy as np


def lame_from_young(E, nu, plane="strain"):
    raise NotImplementedError


def deformation_gradient_p1(X_nodes, x_nodes):
    dX = X_nodes[:, 1:] - X_nodes[:, :1]
    dx = x_nodes[:, 1:] - x_nodes[:, :1]
    return (dx @ np.linalg.inv(dX)).T


def linear_elastic_stress_2d(F, lam, mu):
    raise NotImplementedError
'''

# Chapter 1 answered by the library: the two-line kind of answer that used to pass every check.
CH01_IMPORTS_LIBRARY = '''
from tissuefem.workbook.answers import linear_modulus_1d
from tissuefem.workbook.answers import assemble_stiffness_1d
'''

# Chapter 2: the stress borrowed from the library without an import statement or a string naming
# the package (only the watch during the call sees it); the tangent and the Newton step honest.
CH02_BORROWS_THE_STRESS = CH02_SLIPS.replace('''
def neo_hookean_stress_1d(F, lam, mu):
    F = np.asarray(F, dtype=float)
    return mu * F + (lam * np.log(F) + mu) / F
''', '''
def _borrow(name):
    loaded = vars(__import__("sys"))["mod" + "ules"]
    return getattr(loaded["tissue" + "fem.workbook.answers"], name)


def neo_hookean_stress_1d(F, lam, mu):
    return _borrow("neo_hookean_stress_1d")(F, lam, mu)
''').replace("return 2 * (mu +", "return (mu +").replace("q[1:])", "-q[1:])")


def _grade(tmp_path, files, *args):
    folder = tmp_path / "handed_in"
    folder.mkdir(parents=True)
    for name, text in files.items():
        (folder / name).write_text(textwrap.dedent(text))
    run = subprocess.run([sys.executable, "-m", "tissuefem", "grade", *args, "--exercises", str(folder)],
                         cwd=ROOT, capture_output=True, text=True, timeout=120)
    return run.returncode, run.stdout + run.stderr


def _lines_with(out, *words):
    return [line for line in out.splitlines() if all(w in line for w in words)]


# --- the diagnosis ------------------------------------------------------------------------------

def test_diagnose_names_the_common_slips():
    expected = np.array([[1.0, 2.0], [3.0, 4.0]])
    assert "sign slip" in grading.diagnose(-expected, expected)
    assert "2×" in grading.diagnose(2 * expected, expected)
    assert "½×" in grading.diagnose(0.5 * expected, expected)
    assert "transpose" in grading.diagnose(expected.T, expected)
    assert "3/2" in grading.diagnose(1.5 * expected, expected)
    # a field of tensors in scikit-fem's layout [i, j, elements, points]
    field = np.random.default_rng(0).normal(size=(2, 2, 3, 4))
    assert "transpose" in grading.diagnose(field.transpose(1, 0, 2, 3), field)
    assert "shape (3, 2) is the transpose" in grading.diagnose(np.zeros((3, 2)), np.ones((2, 3)))
    assert "NaN" in grading.diagnose([1.0, np.nan], [1.0, 2.0])
    assert "wrong sign at (1,)" in grading.diagnose([1.0, -2.0, 3.0], [1.0, 2.0, 3.0])


def test_diagnose_uses_the_terms_and_the_slips_a_test_supplies():
    F = np.array([0.5, 1.0, 2.0])
    terms = {"μF": 2 * F, "−μ/F": -2 / F, "λ ln F / F": 3 * np.log(F) / F}
    expected = sum(terms.values())
    assert grading.diagnose(expected - terms["−μ/F"], expected, terms=terms) == "missing term: −μ/F"
    assert grading.diagnose(expected - 2 * terms["μF"], expected, terms=terms) == "sign slip in the term μF"
    assert "λ ln F / F is counted twice" in grading.diagnose(expected + terms["λ ln F / F"], expected, terms=terms)
    assert grading.diagnose(expected + 1, expected, slips={"forgot the 1": expected + 1}) == "forgot the 1"
    # nothing recognised: the hint says what was ruled out
    assert "not a common slip" in grading.diagnose(expected + np.array([0.1, 0.7, -0.2]), expected, terms=terms)


def test_a_wrong_answer_carries_its_values_and_hint():
    with pytest.raises(grading.WrongAnswer) as info:
        grading.assert_close([-1.0, -2.0], [1.0, 2.0], "P(F)")
    assert info.value.hint.startswith("sign slip") and "hint: sign slip" in str(info.value)
    np.testing.assert_array_equal(info.value.got, [-1.0, -2.0])


# --- the student's summary ----------------------------------------------------------------------

def test_three_slips_in_chapter_2_give_a_short_summary_with_hints(tmp_path):
    code, out = _grade(tmp_path, {"ch02.py": CH02_SLIPS}, "ch02")
    assert code == 1, out
    assert "failed checks (11)" in out
    assert len(_lines_with(out, "2.1 neo_hookean_stress_1d", "sign slip in the term −μ/F")) == 4, out
    assert len(_lines_with(out, "2.2 neo_hookean_tangent_1d", "factor slip: 2×")) == 4, out
    assert len(_lines_with(out, "2.3 newton_step_1d", "the update has the wrong sign")) == 3, out
    # each line shows the expected and the obtained value: P(F = 0.2) for lam = mu = 1
    row = _lines_with(out, "2.1", "[lam=1, mu=1]")[0]
    assert "-12.8472 at [0]" in row and "-2.84719 at [0]" in row, row
    assert "Traceback" not in out and "def neo_hookean" not in out
    assert len(out.splitlines()) < 60, f"{len(out.splitlines())} lines:\n{out}"


def test_a_transposed_answer_is_named(tmp_path):
    code, out = _grade(tmp_path, {"ch03.py": CH03_TRANSPOSE}, "ch03")
    assert code == 1, out
    rows = _lines_with(out, "3.2 deformation_gradient_p1", "transpose slip")
    assert len(rows) == 5, out  # six triangles; the one that does not move has F = I = F^T
    assert "not attempted yet: 3.1, 3.3" in out
    assert len(out.splitlines()) < 30, out


# --- the instructor mode ------------------------------------------------------------------------

def test_library_use_is_found_in_the_syntax_tree():
    use = grading.library_use
    assert use('"""Run python -m tissuefem grade."""\nimport numpy as np\n') == []
    assert "imports tissuefem" in use("import tissuefem.engine as e\n")[0]
    assert "imports from tissuefem" in use("def f():\n    from tissuefem import lame_parameters\n")[0]
    assert "through import_module" in use("import importlib\nm = importlib.import_module('tissuefem.engine')\n")[0]
    assert "computed name" in use("name = 'x'\nm = __import__(name)\n")[0]
    assert "sys.modules" in use("import sys\nm = sys.modules['numpy']\n")[0]
    assert "exec()" in use("exec('import os')\n")[0]
    assert "caller's frames" in use("import sys\ng = sys._getframe(1).f_globals\n")[0]


def test_instructor_mode_refuses_answers_that_import_or_run_the_library_and_accepts_honest_work(tmp_path):
    files = {"ch01.py": CH01_IMPORTS_LIBRARY, "ch02.py": CH02_BORROWS_THE_STRESS}
    code, out = _grade(tmp_path / "instructor", files, "--instructor")
    assert code == 1, out
    # read from the syntax tree: one line per function, for all of its checks, naming its own import
    for label, line, n in (("1.1 linear_modulus_1d", 2, 4), ("1.2 assemble_stiffness_1d", 3, 4)):
        rows = _lines_with(out, label, f"REFUSED: ch01.py line {line}: imports from tissuefem")
        assert len(rows) == 1 and f"all {n} checks" in rows[0], out
        assert _lines_with(out, label, f"0/{n} checks passed", "refused"), out
    # seen while it runs
    rows = _lines_with(out, "2.1 neo_hookean_stress_1d", "REFUSED", "runs the library's code when called",
                       "tissuefem/workbook/answers.py:neo_hookean_stress_1d")
    assert len(rows) == 1, out
    # the student's own work passes: the watch sees numpy, not the library
    assert _lines_with(out, "2.2 neo_hookean_tangent_1d", "4/4 checks passed"), out
    assert _lines_with(out, "2.3 newton_step_1d", "3/3 checks passed"), out
    # one failure per refused function, not one per check
    assert "failed checks (3)" in out
    # the student mode does not look: there the borrowed answers pass
    code, out = _grade(tmp_path / "student", files)
    assert code == 0 and "REFUSED" not in out, out
    assert _lines_with(out, "1.1 linear_modulus_1d", "4/4 checks passed"), out


# Chapter 1: the library imported at the top under another name and used by one function; the
# other function is still the untouched stub.
CH01_ONE_CHEAT_AT_THE_TOP = """
import numpy as np
import tissuefem.workbook.answers as reference

SCALE = 1.0


def linear_modulus_1d(lam, mu):
    return SCALE * reference.linear_modulus_1d(lam, mu)


def assemble_stiffness_1d(nodes, modulus):
    raise NotImplementedError("Exercise 1.2")
"""

# Chapter 2: the stress imports the answer inside its body, through a helper; the tangent and
# the Newton step are the untouched stubs.
CH02_ONE_CHEAT_BESIDE_STUBS = """
import numpy as np


def _answer():
    from tissuefem.workbook.answers import neo_hookean_stress_1d
    return neo_hookean_stress_1d


def neo_hookean_stress_1d(F, lam, mu):
    return _answer()(F, lam, mu)


def neo_hookean_tangent_1d(F, lam, mu):
    raise NotImplementedError("Exercise 2.2")


def newton_step_1d(nodes, u, lam, mu, traction):
    raise NotImplementedError("Exercise 2.3")
"""


def test_instructor_mode_refuses_only_the_function_that_uses_the_library(tmp_path):
    files = {"ch01.py": CH01_ONE_CHEAT_AT_THE_TOP, "ch02.py": CH02_ONE_CHEAT_BESIDE_STUBS}
    code, out = _grade(tmp_path, files, "--instructor")
    assert code == 1, out
    # exactly one failure for each cheat, whatever the number of its checks
    assert "failed checks (2)" in out, out
    assert "2 failed" in out.splitlines()[-1], out
    rows = _lines_with(out, "1.1 linear_modulus_1d", "all 4 checks",
                       "REFUSED: ch01.py line 3: imports tissuefem", "used by linear_modulus_1d through reference")
    assert len(rows) == 1, out
    rows = _lines_with(out, "2.1 neo_hookean_stress_1d", "all 4 checks", "REFUSED: ch02.py line 6: imports from",
                       "used by neo_hookean_stress_1d through _answer")
    assert len(rows) == 1, out
    # the stubs beside the cheats are not attempted, not refused
    assert "not attempted yet: 1.2, 2.2, 2.3" in out, out
    assert not _lines_with(out, "1.2 assemble_stiffness_1d", "REFUSED"), out
