"""The grading harness itself: a wrong answer fails and shows expected vs obtained."""

import numpy as np
import pytest

import grading


def test_wrong_answer_message_shows_expected_and_got():
    with pytest.raises(AssertionError) as info:
        grading.assert_close([1.0, 2.0], [1.0, 2.5], "P(F)")
    message = str(info.value)
    assert "expected" in message and "got" in message and "2.5" in message


def test_wrong_shape_is_reported():
    with pytest.raises(AssertionError, match="shape"):
        grading.assert_close(np.zeros(3), np.zeros(4), "u")


def test_student_stub_is_skipped_and_answer_is_graded(tmp_path, monkeypatch):
    (tmp_path / "chXX.py").write_text(
        "def stub(x):\n    raise NotImplementedError\n\ndef wrong(x):\n    return x + 1\n"
    )
    monkeypatch.setattr(grading, "EXERCISES_DIR", tmp_path)
    grading._modules.pop("chXX", None)
    with pytest.raises(pytest.skip.Exception):
        grading.StudentAnswer("chXX", "stub")(1.0)
    with pytest.raises(AssertionError, match="expected"):
        grading.assert_close(grading.StudentAnswer("chXX", "wrong")(1.0), 1.0, "identity")
    grading._modules.pop("chXX", None)


def test_every_stub_exists_for_every_graded_exercise():
    # each chapter file graded in test_exercises.py defines the functions the tests call
    import ast

    for chapter, names in {"ch01": ["linear_modulus_1d", "assemble_stiffness_1d"],
                           "ch02": ["neo_hookean_stress_1d", "neo_hookean_tangent_1d", "newton_step_1d"]}.items():
        tree = ast.parse((grading.EXERCISES_DIR / f"{chapter}.py").read_text())
        defined = {n.name for n in tree.body if isinstance(n, ast.FunctionDef)}
        assert set(names) <= defined, f"{chapter}.py lacks {set(names) - defined}"
