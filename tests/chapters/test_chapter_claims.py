"""The numbers the chapters quote, recomputed from the same runs the chapters make.

A sentence of a chapter that quotes or compares numbers is pinned here, so that a
change of the engine which changes the number also fails a test (chapter 9's claims
about its recorded study are pinned in ``test_bench_accuracy_cost.py``).
"""

import numpy as np
import pytest

from tissuefem import Bar1D, NeoHookean1D, TaylorNeoHookean1D, Traction, lame_parameters


# --- chapter 2 -------------------------------------------------------------------------------------

def test_ch02_the_taylor_model_is_softer_in_compression():
    """"Under the same push T = -1500 the Taylor bar is squeezed to F ~ 0.41, the ln J bar only to F ~ 0.48"."""
    lam, mu = lame_parameters(E=1000.0, nu=0.3)
    bar = Bar1D(0.0, 1.0, n=8)
    stretch = {}
    for name, kwargs, material in [("log", dict(load_steps=10), NeoHookean1D(lam, mu)),
                                   ("taylor", dict(), TaylorNeoHookean1D(lam, mu))]:
        u, results = bar.solve_nonlinear(material, right=Traction(-1500.0), **kwargs)
        assert results[-1].converged
        stretch[name] = 1 + (u[bar.dof_b] - u[bar.dof_a])
    assert stretch["taylor"] < stretch["log"]  # softer: squeezed further by the same load
    assert round(stretch["taylor"], 2) == 0.41 and round(stretch["log"], 2) == 0.48


# --- chapter 6b ------------------------------------------------------------------------------------

def test_ch06b_the_crush_in_frames_folds_instead_of_inverting():
    """"Given a few frames more, the ITF block goes past flat to 1.3 ... no inverted element at all, and a mesh
    folded over itself (most centroids covered twice). Released, it does not come back ...; the Taylor block
    stays folded too; only the stable model finds the rest shape again."""
    from tissuefem.workbook.hardcases import block, crush_in_frames, inversion_models

    mesh, models = block(), inversion_models()
    runs = {name: crush_in_frames(models[name], mesh)
            for name in ("ITF-clamped neo-Hookean", "Taylor neo-Hookean", "stable neo-Hookean")}
    for name, run in runs.items():
        assert run["reached"] == pytest.approx(1.3) and run["converged"], name
        assert run["inverted"] == 0 and run["folded"] > mesh.t.shape[1] / 2, name
    assert runs["ITF-clamped neo-Hookean"]["frames"] > 13  # it needed frames beyond the 13 of the crush
    assert runs["ITF-clamped neo-Hookean"]["released"].rest_error > 0.5
    assert runs["Taylor neo-Hookean"]["released"].rest_error > 0.5
    assert runs["stable neo-Hookean"]["released"].rest_error < 1e-8


# --- chapter 7 -------------------------------------------------------------------------------------

def test_ch07_explicit_steps_per_frame():
    """"About 3 steps per frame on the coarsest mesh and about 48 on the finest: the step count doubles with
    each halving of h" and "From about 12 steps per frame at ... to about 130 at ... on the same mesh: at
    64 × 32 cells that would be some five hundred steps per frame" (nu = 0.3 and 0.499)."""
    from tissuefem import FRAME_BUDGET, Handle, Model, StableNeoHookean, critical_time_step, rectangle
    from tissuefem.workbook.figures.dynamics import CFL_SIZES
    from tissuefem.workbook.timestepping import cfl_study

    assert CFL_SIZES[0] == 4 and CFL_SIZES[-1] == 64
    study = cfl_study((CFL_SIZES[0], CFL_SIZES[-1]))
    coarse, fine = (FRAME_BUDGET / r["dt_measured"] for r in study.rows)
    assert round(coarse) == 3 and 45 <= fine <= 50
    assert fine / coarse == pytest.approx(16, rel=0.05)  # four halvings of h, twice the steps each

    def steps(nu):
        model = Model(rectangle(2.0, 1.0, 16, 8), StableNeoHookean.from_young(1000.0, nu), handles=[Handle("left")],
                      density=1.0)
        return FRAME_BUDGET / critical_time_step(model)

    soft, incompressible = steps(0.3), steps(0.499)
    assert round(soft) == 12 and 120 <= incompressible <= 140
    assert 450 <= fine * incompressible / soft <= 550


# --- chapter 8 -------------------------------------------------------------------------------------

def test_ch08_the_probe_leaves_the_same_penetration_on_every_mesh():
    """"The same push leaves the same penetration on every mesh: ... agree to within a few per cent (the test
    suite checks 600 to 12 000 triangles)" -- the surface-weighted penalty of ``terms.Probe``."""
    from tissuefem.workbook.procedures import probe_indentation

    left = [probe_indentation(n)["penetration"] for n in (600, 1200, 4800, 12000)]
    assert max(left) / min(left) < 1.05, left
    assert 1e-3 < min(left) < 1e-2  # about 1.4 % of the radius 0.25 at the default stiffness 100 E / R


def test_ch08_stiffer_probes_leave_less_penetration_and_cost_newton_steps():
    """"Ten times the stiffness leaves about a third of the penetration (for k ... and costs Newton steps: from 4
    or 5 per frame at k = ... to 11 to 17 at" (chapter 8a; k from 1e4 to 1e8)."""
    from tissuefem.workbook.procedures import probe_indentation

    runs = {k: probe_indentation(1200, stiffness=k) for k in (1e4, 1e6, 1e7, 1e8)}
    for k in (1e6, 1e7):
        assert 2.5 < runs[k]["penetration"] / runs[10 * k]["penetration"] < 4.0
    assert all(4 <= n <= 5 for n in runs[1e4]["newton"])
    assert all(11 <= n <= 17 for n in runs[1e8]["newton"])


def test_ch08_effects_table_newton_counts():
    """Chapter 8b's reading of the effects table: linear rows 1.00 Newton step per frame (the linearised start),
    the quasistatic base 2.00, with inertia 2.38, the projected tangent as many as the base."""
    from tissuefem.workbook.bench.scenes import effects_benchmark

    rows = {r["variant"]: r for r in effects_benchmark(n_triangles=1000, frames=8, out=None, progress=None)["rows"]}
    newton = {name.split(":")[0].split(" (")[0]: r["newton"] for name, r in rows.items()}
    assert newton["linear, constant factorisation"] == 1.0 and newton["linear, general Newton loop"] == 1.0
    assert newton["base"] == 2.0
    assert newton["+ inertia"] == pytest.approx(2.375)
    assert newton["+ inversion"] == newton["base"]


def test_ch08b_a_dynamic_frame_takes_two_newton_steps_after_the_first_frames():
    """Chapter 8b: with inertia "a dynamic frame starts from a prediction of the motion (chapter 7) and takes two
    Newton steps after it, and three in the first frames", on the effects table's drag (1000 triangles, 8 frames)."""
    from tissuefem import Scene, Simulation
    from tissuefem.workbook.bench.scenes import variants
    from tissuefem.workbook.timestepping import flap_drag

    data, options = next((d, o) for name, d, o in variants(1000) if name == "+ inertia")
    counts = [r.newton_iterations for r in flap_drag(Simulation(Scene.from_dict(data), **options), 8)]
    first = counts.index(2)
    assert 0 < first <= 3 and set(counts[:first]) == {3} and set(counts[first:]) == {2}, counts


def test_every_test_the_readme_and_docs_cite_exists():
    """The errata list and the docs cite tests as evidence (``tests/engine/test_x.py::test_y``): each must still be there."""
    import re
    from pathlib import Path

    root = Path(__file__).resolve().parents[2]
    texts = [root / "README.md", *sorted((root / "docs").glob("*.md"))]
    cited = {m for path in texts for m in re.findall(r"(tests/(?:\w+/)?test_\w+\.py)::(\w+)", path.read_text())}
    assert cited, "no citation found: the pattern no longer matches the README"
    for test_file, name in sorted(cited):
        source = (root / test_file).read_text() if (root / test_file).exists() else ""
        assert re.search(rf"^def {name}\b", source, re.M), f"{test_file}::{name} is cited but does not exist"
