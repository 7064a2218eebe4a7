"""Figures regenerate deterministically; the command line works."""

import matplotlib

matplotlib.use("Agg")

import pytest

from helpers import assert_figure_deterministic
from tissuefem.workbook import cli

from tissuefem.workbook import figures

FAST_FIGURES = ["fig05_admissible_maps", "fig07_neo_hookean_1d", "fig_ch01_convergence", "fig_ch02_newton"]


@pytest.mark.parametrize("name", FAST_FIGURES)
def test_figure_is_deterministic(tmp_path, name):
    assert_figure_deterministic(name, tmp_path)  # the committed file, byte for byte


def test_every_figure_has_a_docstring_and_unknown_names_are_rejected():
    assert set(FAST_FIGURES) <= set(figures.FIGURES)
    for name, func in figures.FIGURES.items():
        assert func.__doc__, name
    with pytest.raises(ValueError, match="unknown figure"):
        figures.generate(["no_such_figure"], "unused", progress=None)


def test_cli_figures_and_list(tmp_path, capsys):
    assert cli.main(["figures", "--only", "fig05_admissible_maps", "--out", str(tmp_path)]) == 0
    assert (tmp_path / "fig05_admissible_maps.png").exists()
    assert "[figure 1/1]" in capsys.readouterr().out
    assert cli.main(["list"]) == 0
    out = capsys.readouterr().out
    assert "fig07_neo_hookean_1d" in out and "ch01_" in out


def test_the_installed_tissuefem_command_runs(tmp_path):
    """``pip install`` puts a ``tissuefem`` command on the PATH beside the interpreter; it must start."""
    import shutil
    import subprocess
    import sys
    from pathlib import Path

    exe = Path(sys.executable).parent / "tissuefem"
    if not exe.exists():
        exe = shutil.which("tissuefem")
    if exe is None:
        pytest.skip("the package is not installed with its console script (pip install -e .)")
    done = subprocess.run([str(exe), "list"], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    assert "fig07_neo_hookean_1d" in done.stdout


def test_a_refused_option_is_named_by_its_field(capsys):
    """The command line reads ``ParameterError.field`` to name the option, as argparse names its own."""
    with pytest.raises(SystemExit) as exit_:
        cli.main(["bench", "assembly", "--repeats", "0"])
    assert exit_.value.code == 2
    err = capsys.readouterr().err
    assert "argument --repeats: repeats must be an integer" in err and "Traceback" not in err


def test_a_scene_field_error_is_one_line_with_the_path(monkeypatch, tmp_path, capsys):
    from tissuefem.engine.parameters import ParameterError

    def refuse(path):
        raise ParameterError("material.poisson_ratio", "material.poisson_ratio must lie in [0, 0.5), got 0.7")

    monkeypatch.setattr(cli.Scene, "load", staticmethod(refuse))
    assert cli.main(["scene", str(tmp_path / "s.toml"), "--check"]) == 2
    err = capsys.readouterr().err.splitlines()
    assert err == [f"{tmp_path / 's.toml'}: material.poisson_ratio must lie in [0, 0.5), got 0.7"]
