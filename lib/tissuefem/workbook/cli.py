"""Command line: ``python -m tissuefem {figures,build,book,bench,scene,grade,list}``.

Each subcommand's ``--help`` (the parser in :func:`main`) and the README say what it does. A refused argument is
answered with one line on stderr naming it, and exit status 2, before any work starts.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import time
import warnings
from pathlib import Path

import matplotlib
import numpy as np

from ..engine.linsolve import LinearSolver
from ..engine.meshes import MAX_TRIANGLES
from ..engine.parameters import ParameterError, check_count
from ..surgery.scene import Scene
from ..surgery.simulation import Simulation
from . import figures
from .bench.accuracy_cost import accuracy_study
from .bench.assembly import assembly_benchmark
from .bench.haptic import haptic_benchmark
from .bench.realtime import realtime_benchmark, solver_comparison
from .bench.scenes import effects_benchmark
from .book import build_book
from .figures.tradeoffs import plot_budget, plot_pareto, plot_realtime, plot_scaling
from .notebooks import build_chapters, chapter_paths


def project_root() -> Path:
    """The workbook folder: the current directory if it holds ``chapters/``, else the package's checkout."""
    for root in (Path.cwd(), Path(__file__).resolve().parents[3]):
        if (root / "chapters").is_dir():
            return root
    raise SystemExit("cannot find the workbook's chapters/ folder: run this from the workbook's root folder")


class _Parser(argparse.ArgumentParser):
    """argparse, but a refused argument is one line on stderr (exit status 2), without the usage text."""

    def error(self, message):
        self.exit(2, f"{self.prog}: error: {' '.join(message.split())}\n")


def _checked(check):
    """An argparse ``type``: ``check(text)``'s value; its :class:`ParameterError` becomes argparse's error."""
    def parse(text):
        try:
            return check(text)
        except ParameterError as err:
            raise argparse.ArgumentTypeError(str(err)) from None
    return parse


def _count(name, lo, hi):
    """An argparse ``type``: an integer in ``[lo, hi]`` (other text and 30-digit numbers refused as text)."""
    def check(text):
        return check_count(name, int(text) if text.lstrip("+-").isdecimal() and len(text) < 30 else text, lo, hi)
    return _checked(check)


def _folder(name, what=""):
    """An argparse ``type``: an existing folder."""
    def check(text):
        if not Path(text).is_dir():
            raise ParameterError(name, f"{text} is not a folder{what}")
        return text
    return _checked(check)


@_checked
def _figure(name):
    if name not in figures.FIGURES:
        raise ParameterError("only", f"unknown figure {name!r} (see `list`)")
    return name


@_checked
def _linear_solver(name):
    LinearSolver(name)  # refuses an unknown name or a backend that is not installed
    return name


def _check_out(path) -> Path | None:
    """The output folder ``path`` as a Path, refused if it is a file or lies below one; none given: ``None`` (the
    caller's default place)."""
    if not path:
        return None
    path = Path(path)
    try:
        below = next((p for p in path.parents if p.exists() and not p.is_dir()), None)
        clash = path.exists() and not path.is_dir()
    except (OSError, ValueError) as err:  # ValueError: a NUL character, which no file name can hold
        raise ParameterError("out", f"{path} cannot be used: {getattr(err, 'strerror', None) or err}") from None
    if below is not None:
        raise ParameterError("out", f"{path} lies below {below}, which is not a folder")
    if clash:
        raise ParameterError("out", f"{path} is not a folder")
    return path


def _figures(names, out, note: bool) -> None:
    """Regenerate figures (a note when this matplotlib would change the committed ones' text)."""
    matplotlib.use("Agg")
    figures.generate(names, out)
    if note and figures.matplotlib_note():
        print(figures.matplotlib_note())


def cmd_figures(args) -> int:
    _figures(args.only or None, _check_out(args.out) or project_root() / "figures", not args.out)
    return 0


def cmd_build(args) -> int:
    start = time.perf_counter()
    root = project_root()
    names = [p.name for p in chapter_paths(root / "chapters")]
    for wanted in args.chapters or []:
        if not any(wanted in name for name in names):
            raise ParameterError("chapters", f"no chapter file name contains {wanted!r} (see `list`)")
    executed = _check_out(args.out) or root / "build" / "chapters"
    if not args.skip_figures:
        _figures(None, root / "figures", True)
    build_chapters(root / "chapters", executed, args.chapters)
    if not args.no_book:
        build_book(root / "chapters", executed, root / "build" / "book")
        print(f"the workbook's website: {root / 'build' / 'book' / 'index.html'}")
    print(f"build finished in {time.perf_counter() - start:.1f} s")
    return 0


def cmd_book(args) -> int:
    root = project_root()
    out = _check_out(args.out or root / "build" / "book")
    build_book(root / "chapters", Path(args.executed) if args.executed else root / "build" / "chapters", out)
    print(f"the workbook's website: {out / 'index.html'} (copy the folder to any web server)")
    return 0


def cmd_bench(args) -> int:
    if (args.which in ("scenes", "haptic") or (args.which == "realtime" and args.compare)) and args.sizes:
        if len(args.sizes) > 1:
            which = "realtime --compare" if args.which == "realtime" else args.which
            raise ParameterError("sizes", f"bench {which} takes one size, got {len(args.sizes)}")
        check_count("sizes", args.sizes[0], 50, MAX_TRIANGLES)  # the scenes' variants need 50 triangles
    out = _check_out(args.out or "bench-results")
    matplotlib.use("Agg")
    if args.which == "assembly":
        assembly_benchmark(sizes=args.sizes or (2000, 8000, 32000), repeats=args.repeats, out=out)
    elif args.which == "realtime" and args.compare:
        solver_comparison(n=args.sizes[0] if args.sizes else 19000, frames=args.frames, dim=args.dim, out=out)
    elif args.which == "realtime":
        rows = realtime_benchmark(sizes=args.sizes, frames=args.frames, baseline_frames=args.baseline_frames,
                                  linear_solver=args.linear, out=out, dim=args.dim)
        if args.dim == 2:
            plot_realtime(rows, out / "realtime.png")
            print(f"wrote {out / 'realtime.png'}")
    elif args.which == "scenes":
        size = args.sizes[0] if args.sizes else 8000
        effects_benchmark(n_triangles=size, frames=min(args.frames, 90), repeats=args.repeats, out=out)
    elif args.which == "haptic":
        haptic_benchmark(n_triangles=args.sizes[0] if args.sizes else 8000, frames=args.frames,
                         linear_solver=args.linear or "reuse-background", out=out)
    else:  # accuracy
        results = accuracy_study(plan=args.plan, out=out)
        for plot, stem, key in ((plot_pareto, "pareto", "knobs"), (plot_scaling, "scaling", "scaling"),
                                (plot_budget, "budget", "budget")):
            if results.get(key):
                plot(results, out / f"accuracy_{stem}.png")
                print(f"wrote {out / f'accuracy_{stem}.png'}")
    return 0


def cmd_grade(args) -> int:
    """Grade only the student's answers; ends with one line per failed check (tests/conftest.py)."""
    root = project_root()
    env = dict(os.environ, TISSUEFEM_GRADE="instructor" if args.instructor else "student")
    if args.exercises:
        env["TISSUEFEM_EXERCISES"] = str(Path(args.exercises).resolve())
    tests = sorted((root / "tests" / "chapters").glob("test_exercises*.py"))
    if args.chapter:
        # only the files that grade this chapter: quicker to collect
        tests = [t for t in tests if f'"{args.chapter}"' in t.read_text(encoding="utf-8")] or tests
    cmd = [sys.executable, "-m", "pytest", *map(str, tests), "-q", "--disable-warnings"]
    if args.chapter:
        cmd += ["-k", args.chapter]
    return subprocess.call(cmd, env=env, cwd=root)


def _one_line(path, err) -> str:
    """An error as the single line the ``scene`` command prints: ``PATH: message``, the path once (an error about
    a field inside the file names the field, one about the file itself may already name the path)."""
    message = " ".join(str(err).split()) or type(err).__name__
    about_a_field = isinstance(err, ParameterError) and err.field != "path"
    return f"{path}: {message}" if about_a_field or str(path) not in message else message


def cmd_scene(args) -> int:
    """Check a scene file and run it: one line per frame (``--verbose``), then a summary. A scene that cannot
    be read or built is answered with one line on stderr and exit status 2, never a traceback."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            scene = Scene.load(args.path)
            sim = Simulation(scene)
        except (ValueError, OSError) as err:
            print(_one_line(args.path, err), file=sys.stderr)
            return 2
        except Exception as err:  # a failure the checks did not foresee: still one line, and worth reporting
            print(_one_line(args.path, f"unexpected {type(err).__name__} while building the scene: {err} "
                                       "(please report this scene file)"), file=sys.stderr)
            return 2
    for w in caught:
        print(f"{args.path}: warning: {' '.join(str(w.message).split())}", file=sys.stderr)
    noun = "triangles" if sim.model.dim == 2 else "tetrahedra"
    print(f"{scene.name}: {sim.mesh.nelements} {noun}, terms {sim.terms}, handles {list(sim.handles)}")
    for note in scene.notes:
        print(f"note: {note}")
    if args.check:
        return 0
    ms = []
    for _ in range(args.frames):
        r = sim.frame()
        ms.append(1e3 * r.elapsed)
        if args.verbose:
            print(f"  frame {r.frame:4d}  {ms[-1]:7.1f} ms  {r.status:18s} Newton {r.newton_iterations}")
    finite = bool(np.all(np.isfinite(sim.u)))
    print(f"{args.frames} frames: median {np.median(ms):.1f} ms/frame (budget {1e3 * sim.solver.budget:.0f} ms), "
          f"max {max(ms):.1f} ms; {sim.pieces()} piece(s); state finite: {finite}")
    return 0 if finite else 1


def cmd_list(args) -> int:
    print("figures:")
    for name, func in figures.FIGURES.items():
        print(f"  {name:32s} {(func.__doc__ or '').strip().splitlines()[0]}")
    print("chapters:")
    for p in chapter_paths(project_root() / "chapters"):
        print(f"  {p.name}")
    return 0


def main(argv=None) -> int:
    parser = _Parser(prog="python -m tissuefem", description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command", required=True)

    p = sub.add_parser("figures", help="regenerate every lecture figure into figures/")
    p.add_argument("--only", nargs="+", metavar="NAME", type=_figure, help="only these figures (see `list`)")
    p.add_argument("--out", help="output folder (default: figures/)")

    p = sub.add_parser("build", help="regenerate figures, execute every chapter headless and write the website")
    p.add_argument("--chapters", nargs="+", metavar="NAME", help="only chapters whose file name contains NAME")
    p.add_argument("--skip-figures", action="store_true", help="do not regenerate figures/")
    p.add_argument("--out", help="folder for executed notebooks (default: build/chapters/)")
    p.add_argument("--no-book", action="store_true", help="do not write the website build/book/")

    p = sub.add_parser("book", help="write the workbook's website from the executed chapters")
    p.add_argument("--executed", type=_folder("executed"),
                   help="folder of executed notebooks (default: build/chapters/)")
    p.add_argument("--out", help="folder for the website (default: build/book/)")

    p = sub.add_parser("bench", help="run a benchmark and print its table")
    p.add_argument("which", choices=["assembly", "realtime", "scenes", "accuracy", "haptic"],
                   help="assembly, realtime (--dim 3: the 3D block, --compare: the linear solvers side by side), "
                        "scenes (each effect's cost), accuracy (chapter 9's study), haptic (the tool's force at 1 kHz)")
    p.add_argument("--sizes", type=_count("sizes", 1, MAX_TRIANGLES), nargs="+",
                   help=f"approximate triangle counts, with --dim 3 tetrahedra (at most {MAX_TRIANGLES})")
    p.add_argument("--repeats", type=_count("repeats", 1, 1000), default=5,
                   help="assembly, scenes: timed repetitions")
    p.add_argument("--frames", type=_count("frames", 1, 1_000_000), default=90,
                   help="realtime, haptic: frames of the scripted drag")
    p.add_argument("--baseline-frames", type=_count("baseline_frames", 0, 1_000_000),
                   help="realtime: frames of the ex43-way baseline (default 10 in 2D, 0 in 3D)")
    p.add_argument("--linear", type=_linear_solver,
                   help="realtime: linear solver (default reuse-background in 2D, the real-time solver's own in "
                        "3D; reuse, reuse-pardiso, direct, superlu, superlu-colamd, pardiso, or "
                        "reuse-background-<backend> with cholmod, pardiso, cg-amg)")
    p.add_argument("--dim", type=int, choices=[2, 3], default=2,
                   help="realtime: 2 (the flap; sizes in triangles) or 3 (a block held on one face, dragged by "
                        "the opposite one; sizes in tetrahedra, default 5000 19000 40000 100000)")
    p.add_argument("--compare", action="store_true",
                   help="realtime: one size (default 19000) with each linear solver in turn, alternating: "
                        "factorization, back-substitution, fill-in, assembly and the frames")
    p.add_argument("--plan", default="full", choices=["full", "reduced", "tiny"],
                   help="accuracy: the sweep (full: several minutes; reduced: chapter 9's; tiny: seconds)")
    p.add_argument("--out", help="folder for the results, JSON and CSV (default bench-results/)")

    p = sub.add_parser("scene", help="check a scene file (TOML or JSON) and run it for some frames")
    p.add_argument("path", help="the scene file, e.g. scenes/incision.toml")
    p.add_argument("--frames", type=_count("frames", 1, 1_000_000), default=30,
                   help="frames to run (default 30, at most 1000000)")
    p.add_argument("--check", action="store_true", help="only check and build the scene")
    p.add_argument("--verbose", "-v", action="store_true", help="one line per frame")

    p = sub.add_parser("grade", help="grade your answers in chapters/exercises with pytest")
    p.add_argument("chapter", nargs="?", help="only this chapter, e.g. ch02")
    p.add_argument("--instructor", action="store_true",
                   help="refuse any answer that imports or runs tissuefem (the reference implementation)")
    p.add_argument("--exercises", metavar="DIR",
                   type=_folder("exercises", " (it should hold ch01.py ... ch11.py)"),
                   help="grade the chNN.py files in DIR (e.g. a student's submission) instead of chapters/exercises")

    sub.add_parser("list", help="list figures and chapters")

    args = parser.parse_args(argv)
    commands = {"figures": cmd_figures, "build": cmd_build, "book": cmd_book, "bench": cmd_bench, "scene": cmd_scene,
                "grade": cmd_grade, "list": cmd_list}
    try:
        return int(commands[args.command](args) or 0)
    except ParameterError as err:  # a refused option value: name the option, as argparse does for its own checks
        if err.field in vars(args):
            sub.choices[args.command].error(f"argument --{err.field.replace('_', '-')}: {err}")
        sub.choices[args.command].error(str(err))  # refused further in: still one line, and no traceback
