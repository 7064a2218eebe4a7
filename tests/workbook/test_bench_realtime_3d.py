"""The 3D frame-rate benchmark (the block held on one face, dragged by the other) on a tiny run: its columns,
the frames' accuracy, the record it writes, the linear solvers side by side (no timing is asserted)."""

import csv
import json

import numpy as np
import pytest

from tissuefem.workbook.bench.realtime import (block_drag, block_path, block_simulation, format_comparison_table,
                                               format_realtime_table, realtime_benchmark, solver_comparison)
from tissuefem.workbook.cli import main


def test_tiny_3d_benchmark_has_the_2d_columns_and_converges(tmp_path):
    rows = realtime_benchmark(sizes=(48, 160), frames=3, budget_frames=2, out=tmp_path, progress=None, dim=3)
    assert [r["tetrahedra"] for r in rows] == sorted(r["tetrahedra"] for r in rows)
    for row in rows:
        assert 40 <= row["tetrahedra"] <= 200 and row["dofs"] % 3 == 0
        for key in ("fast_median_ms", "fast_p95_ms", "fast_p99_ms", "fast_newton", "fast_cg", "floor_ms",
                    "frame_over_floor", "assembly_ms", "back_substitution_ms", "factorization_ms", "factor_nnz",
                    "matrix_nnz", "budget_p95_ms", "budget_p99_ms"):
            assert key in row, key
        assert row["fast_all_converged"] and row["fast_converged"] == 1.0 and row["fast_residual"] <= 1e-6
        assert row["fast_min_J"] > 0 and row["fast_inverted"] == 0 and row["fast_undone"] == "0/3"
        assert row["fast_p95_ms"] <= row["fast_p99_ms"] <= max(row["fast_ms"])
        assert 2 * row["factor_nnz"] >= row["matrix_nnz"] > 0  # the factors hold at least a triangle of K
        assert "ex43_median_ms" not in row  # no ex43 way by default in 3D
    record = json.loads((tmp_path / "realtime3d.json").read_text())
    assert record["benchmark"] == "realtime3d" and record["scene"]["dim"] == 3
    assert record["scene"]["dt"] == pytest.approx(1 / 30) and record["scene"]["rtol"] == 1e-6
    with open(tmp_path / "realtime3d.csv", newline="") as fh:
        assert len(list(csv.DictReader(fh))) == 2
    header = format_realtime_table(rows).splitlines()[0]
    for title in ("tetrahedra", "median [ms]", "p95 [ms]", "p99 [ms]", "Newton/frame", "CG/frame", "floor [ms]",
                  "frame / floor", "median rel. residual", "converged", "min J", "inverted",
                  "in budget: left undone"):
        assert f"| {title} |" in header, title


def test_the_ex43_way_runs_in_3d_and_agrees():
    rows = realtime_benchmark(sizes=(48,), frames=2, baseline_frames=2, budget_frames=0, progress=None, dim=3)
    assert rows[0]["max_state_difference"] < 1e-4 and rows[0]["ex43_newton"] >= 1


def test_the_block_is_held_on_one_face_and_dragged_by_the_other():
    sim = block_simulation(48)
    reports = block_drag(sim, 2)
    assert all(r.converged for r in reports)
    x = sim.model.nodal_displacement(sim.u)
    left, right = np.isclose(sim.mesh.p[0], 0.0), np.isclose(sim.mesh.p[0], 2.0)
    assert np.allclose(x[:, left], 0.0)
    assert np.allclose(x[:, right], block_path(2 / 30)[:, None])
    assert sim.solver.budget > 1e6  # no budget: every frame converges


def test_linear_solvers_side_by_side(tmp_path):
    rows = solver_comparison(48, approaches=("reuse", "reuse-background", "reuse-background-no-such"), frames=2,
                             rounds=2, out=tmp_path, progress=None)
    assert [r["approach"] for r in rows] == ["reuse", "reuse-background"]  # one that cannot run is left out
    for row in rows:
        assert len(row["round_medians_ms"]) == 2 and row["fill"] >= 1.0 and row["fast_converged"] == 1.0
    text = format_comparison_table(rows)
    assert "| factorization [ms] |" in text and "| nnz(factors) / nnz(K) |" in text
    record = json.loads((tmp_path / "realtime3d_solvers.json").read_text())
    assert len(record["load_before_each_run"]) == 4 and record["settings"]["rounds"] == 2


def test_bad_settings_are_refused_by_name():
    with pytest.raises(ValueError, match="dim"):
        realtime_benchmark(sizes=(48,), dim=4, progress=None)
    with pytest.raises(ValueError, match="approaches"):
        solver_comparison(48, approaches=("reuse-background-no-such",), progress=None)


def test_cli_runs_the_3d_benchmark(tmp_path, capsys):
    assert main(["bench", "realtime", "--dim", "3", "--sizes", "48", "--frames", "2", "--out", str(tmp_path)]) == 0
    assert (tmp_path / "realtime3d.json").exists() and not (tmp_path / "realtime.png").exists()
    assert "| tetrahedra |" in capsys.readouterr().out
    with pytest.raises(SystemExit) as refused:
        main(["bench", "realtime", "--compare", "--sizes", "48", "96"])
    assert refused.value.code == 2
