"""The command line refuses bad arguments with one line on stderr naming the argument, and exit status 2.

Every case runs through :func:`~tissuefem.workbook.cli.main` (an uncaught exception would fail the test);
two run as ``python -m tissuefem`` processes too (each costs the package's import time, so not all of them).
"""

import subprocess
import sys
from pathlib import Path

import pytest

from tissuefem.workbook import cli

ROOT = Path(__file__).resolve().parents[2]


def _cases(tmp_path):
    a_file = tmp_path / "a_file"
    a_file.write_text("not a folder")
    missing = tmp_path / "missing"
    return [
        (["bench", "assembly", "--sizes", "0"], "--sizes"),
        (["bench", "assembly", "--sizes", "-5"], "--sizes"),
        (["bench", "assembly", "--sizes", "many"], "--sizes"),
        (["bench", "assembly", "--sizes", "9" * 5000], "--sizes"),
        (["bench", "assembly", "--repeats", "0"], "--repeats"),
        (["bench", "assembly", "--out", str(a_file / "results")], "--out"),
        (["bench", "realtime", "--frames", "0"], "--frames"),
        (["bench", "realtime", "--frames", "-3"], "--frames"),
        (["bench", "realtime", "--linear", "nope"], "--linear"),
        (["bench", "realtime", "--out", str(a_file)], "--out"),
        (["bench", "scenes", "--sizes", "1000000000"], "--sizes"),
        (["bench", "scenes", "--sizes", "10"], "--sizes"),
        (["bench", "scenes", "--sizes", "800", "1600"], "--sizes"),
        (["figures", "--only", "nosuchfigure"], "--only"),
        (["figures", "--out", str(a_file)], "--out"),
        (["build", "--chapters", "zzz_nosuch"], "--chapters"),
        (["book", "--executed", str(missing)], "--executed"),
        (["book", "--out", str(a_file / "site")], "--out"),
        (["grade", "--exercises", str(missing)], "--exercises"),
        (["grade", "--exercises", str(a_file)], "--exercises"),
        (["scene", str(tmp_path / "s.toml"), "--frames", "0"], "--frames"),
    ]


def _check(args, argument, code, err):
    assert code == 2, (args, code, err[-500:])
    assert "Traceback" not in err and len(err.splitlines()) == 1, (args, err[-500:])
    assert f"error: argument {argument}: " in err, (args, err)


def test_every_bad_argument_is_one_line_naming_it_and_status_2(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(ROOT)
    for args, argument in _cases(tmp_path):
        with pytest.raises(SystemExit) as exit_:
            cli.main(args)
        out, err = capsys.readouterr()
        _check(args, argument, exit_.value.code, err)
        assert out == "", (args, out)


@pytest.mark.parametrize("case", [0, 14])
def test_the_command_itself_answers_with_one_line_and_status_2(tmp_path, case):
    args, argument = _cases(tmp_path)[case]
    run = subprocess.run([sys.executable, "-m", "tissuefem", *args], cwd=ROOT, capture_output=True, text=True,
                         timeout=300)
    _check(args, argument, run.returncode, run.stderr)
    assert run.stdout == ""
