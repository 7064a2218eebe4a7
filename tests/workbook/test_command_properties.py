"""Property: ``python -m tissuefem`` answers any argument list with exit status 0 or 2 and never a traceback.

Random argument lists for every subcommand (option names and values from a small alphabet: negative numbers,
0, huge numbers, junk words, missing paths, a regular file where a folder goes, a folder where a file goes,
scene files good and bad) run in-process through :func:`~tissuefem.workbook.cli.main`; the heavy runners
(figures, chapters, the website, benchmarks, pytest) are replaced by stand-ins that return at once, so what is
tested is the argument layer and the checks before any work. A few cases run as real processes.
"""

import argparse
import contextlib
import io
import subprocess
import sys
import types
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from tissuefem.surgery.scene import demo_scene
from tissuefem.workbook import cli

SETTINGS = settings(max_examples=60, deadline=None, derandomize=True, database=None,
                    suppress_health_check=[HealthCheck.too_slow])

# the runners that do real work, each replaced by a stand-in returning what the command expects of it
_STAND_INS = {"_figures": None, "build_chapters": None, "build_book": None, "assembly_benchmark": None,
              "realtime_benchmark": [], "solver_comparison": [], "effects_benchmark": None, "accuracy_study": {}, "haptic_benchmark": {},
              "plot_realtime": None, "plot_pareto": None, "plot_scaling": None, "plot_budget": None}


def _subcommands():
    """The subcommands and the options of each, as ``main``'s parser defines them (read, not copied)."""
    captured = {}

    class Stop(Exception):
        pass

    def capture(self, argv=None, namespace=None):
        captured["parser"] = self
        raise Stop

    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(argparse.ArgumentParser, "parse_args", capture)
        with contextlib.suppress(Stop):
            cli.main([])
    sub = next(a for a in captured["parser"]._actions if isinstance(a, argparse._SubParsersAction))
    return {name: sorted(s for a in p._actions for s in a.option_strings) for name, p in sub.choices.items()}


SUBCOMMANDS = _subcommands()
_HELP = ("-h", "--help")  # help is status 0 at once: among the options, but not the subcommands' own
_OWN = {name: [o for o in options if o not in _HELP] for name, options in SUBCOMMANDS.items()}
ALL_OPTIONS = sorted({o for options in _OWN.values() for o in options}) + ["--nope", "-x", "--", "--help"]
#: each subcommand's positional argument, right or wrong
_POSITIONAL = {"bench": ["assembly", "realtime", "scenes", "accuracy", "haptic", "nope"],
               "scene": ["@good.toml", "@junk.toml", "@nan.json", "@missing", "@a_folder", "@folder.toml"],
               "grade": ["ch01", "ch99", "-1"]}


@pytest.fixture(scope="module")
def place(tmp_path_factory):
    """A workbook root of its own (an empty ``chapters/``) and the files and folders the arguments name."""
    root = tmp_path_factory.mktemp("workbook")
    (root / "chapters").mkdir()
    (root / "a_file").write_text("not a folder")
    (root / "a_folder").mkdir()
    (root / "junk.toml").write_text("[domain\nshape = 'rectangle'")
    (root / "nan.json").write_text('{"domain": {"shape": "rectangle", "width": NaN}}')
    (root / "folder.toml").mkdir()
    demo_scene(n_triangles=60).save(root / "good.toml")
    return root


_PATHS = ["missing", "missing/deeper/x.json", "a_file", "a_file/below", "a_folder", "junk.toml", "nan.json",
          "folder.toml", "good.toml", "a_folder/new.json"]
_VALUES = st.one_of(
    st.sampled_from(["-1", "0", "1", "2", "3", "50", "-5", "9" * 40, "1e9", "nan", "-inf", "2.5", "", " ", "many",
                     "+7", "0x10", "assembly", "realtime", "scenes", "accuracy", "tiny", "full", "reduced",
                     "reuse", "direct", "superlu", "nope", "ch01", "poisson_1d"]),
    st.sampled_from(_PATHS).map(lambda p: "@" + p),  # a path below the test's root, filled in by _argv
)


@st.composite
def _arguments(draw, command):
    own = _OWN.get(command) or ["--out"]
    option = st.one_of(st.sampled_from(own), st.sampled_from(ALL_OPTIONS))
    token = st.one_of(st.tuples(option, _VALUES), st.tuples(option), st.tuples(_VALUES))
    tokens = [t for group in draw(st.lists(token, max_size=4)) for t in group]
    if command in _POSITIONAL and draw(st.integers(0, 3)):  # usually give the positional argument
        tokens.insert(0, draw(st.one_of(st.sampled_from(_POSITIONAL[command]), _VALUES)))
    return [command, *tokens]


def _argv(arguments, root):
    argv = [str(root / a[1:]) if a.startswith("@") else a for a in arguments]
    if argv[0] == "scene" and "--check" not in argv:
        argv.append("--check")  # a scene that builds would otherwise run its frames: the runner's work
    return argv


def run_main(argv):
    """``(status, stdout, stderr)`` of ``cli.main(argv)`` with the heavy runners stood in for."""
    out, err = io.StringIO(), io.StringIO()
    with pytest.MonkeyPatch.context() as mp:
        for name, value in _STAND_INS.items():
            mp.setattr(cli, name, lambda *args, _value=value, **kwargs: _value)
        mp.setattr(cli, "subprocess", types.SimpleNamespace(call=lambda *args, **kwargs: 0))
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            try:
                status = cli.main(argv)
            except SystemExit as exit_:
                status = exit_.code
    return status, out.getvalue(), err.getvalue()


def test_the_alphabet_reaches_every_subcommand():
    assert set(SUBCOMMANDS) == {"figures", "build", "book", "bench", "scene", "grade", "list"}
    assert "--sizes" in SUBCOMMANDS["bench"] and "--check" in SUBCOMMANDS["scene"]


@pytest.mark.parametrize("arguments", [
    ["scene", "@good.toml", "--check"], ["bench", "realtime", "--sizes", "50", "--frames", "3"],
    ["bench", "assembly", "--out", "@a_folder/assembly"], ["bench", "scenes", "--sizes", "800"],
    ["bench", "accuracy", "--plan", "tiny", "--out", "@a_folder/accuracy"], ["figures", "--out", "@a_folder"],
    ["build", "--skip-figures", "--no-book"], ["book", "--executed", "@a_folder", "--out", "@a_folder/site"],
    ["grade", "ch01"], ["list"]])
def test_valid_commands_reach_their_runner_and_status_0(place, arguments):
    """The stand-ins make a valid command return at once, so the random ones below may be valid too."""
    argv = _argv(arguments, place)
    with pytest.MonkeyPatch.context() as mp:
        mp.chdir(place)
        status, out, err = run_main(argv)
    assert status in (0, None) and "Traceback" not in err, (argv, err)


@pytest.mark.parametrize("command", sorted(SUBCOMMANDS) + ["nosuchcommand"])
@SETTINGS
@given(data=st.data())
def test_any_arguments_give_status_0_or_2_and_no_traceback(place, command, data):
    argv = _argv(data.draw(_arguments(command), label="arguments"), place)
    with pytest.MonkeyPatch.context() as mp:
        mp.chdir(place)
        status, out, err = run_main(argv)
    assert status in (0, None, 2), (argv, status, err[-800:])
    assert "Traceback" not in err + out, (argv, err[-800:])
    if status == 2:  # a refusal: one line naming what was wrong (argparse's usage line may come first)
        assert err.strip().splitlines()[-1], (argv, err)


@pytest.mark.parametrize("arguments", [["bench", "scenes", "--sizes", "10"], ["scene", "@nan.json", "--check"]])
def test_the_command_itself_answers_junk_with_status_2_and_no_traceback(place, arguments):
    argv = _argv(arguments, place)
    run = subprocess.run([sys.executable, "-m", "tissuefem", *argv], cwd=place, capture_output=True, text=True,
                         timeout=300)
    assert run.returncode == 2, (argv, run.stderr[-800:])
    assert "Traceback" not in run.stderr and run.stderr.strip(), (argv, run.stderr[-800:])
