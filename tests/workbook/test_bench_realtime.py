"""The frame-rate benchmark's code paths on a tiny run (no timing is asserted)."""

import csv
import json

import numpy as np
import pytest

from tissuefem import flap_path
from tissuefem.workbook.bench.realtime import ex43_frames, flap_simulation, format_realtime_table, realtime_benchmark
from tissuefem.workbook.cli import main


def test_tiny_benchmark_writes_json_and_csv(tmp_path):
    rows = realtime_benchmark(sizes=(150, 300), frames=4, baseline_frames=3, budget_frames=2, out=tmp_path,
                              progress=None)
    assert [r["triangles"] for r in rows] == sorted(r["triangles"] for r in rows)
    record = json.loads((tmp_path / "realtime.json").read_text())
    assert record["benchmark"] == "realtime" and record["scene"]["dt"] == pytest.approx(1 / 30)
    assert "scikit-fem" in record["machine"]
    for row in record["rows"]:
        assert row["fast_all_converged"] and row["linear_solver"].startswith("cg+reused-superlu")
        assert len(row["fast_ms"]) == 4 and len(row["ex43_ms"]) == 3
        assert row["speedup"] > 0 and 0 <= row["budget_converged"] <= 1
        # both ways solve the same scene: the states agree to the Newton tolerance
        assert row["max_state_difference"] < 1e-4
        # the floor (one assembly and one back-substitution) is measured in the same run
        assert 0 < row["floor_ms"] and row["frame_over_floor"] > 0
    with open(tmp_path / "realtime.csv", newline="") as fh:
        table = list(csv.DictReader(fh))
    assert len(table) == 2 and "fast_median_ms" in table[0] and "fast_ms" not in table[0]
    text = format_realtime_table(rows)
    assert text.count("\n") == 3 and "speedup" in text
    # beside the times, the frames' own accuracy
    for title in ("median rel. residual", "converged", "min J", "inverted", "in budget: min J",
                  "in budget: inverted", "in budget: left undone"):
        assert f"| {title} |" in text.splitlines()[0]
    for row in rows:
        assert row["fast_converged"] == 1.0 and row["fast_residual"] <= 1e-6
        assert row["fast_min_J"] > 0 and row["fast_inverted"] == 0 and row["fast_undone"] == "0/4"
        assert 0 < row["budget_min_J"] and row["budget_inverted"] == 0
        done, frames = row["budget_undone"].split(" ")[0].split("/")
        assert frames == "2" and 0 <= int(done) <= 2
        assert row["budget_undone"] == "0/2" or "(" in row["budget_undone"]  # what was left, named


def test_the_ex43_way_and_the_realtime_solver_take_the_same_steps():
    _, iterations, u_ex43 = ex43_frames(flap_simulation(200).model, 3, rtol=1e-10)
    sim = flap_simulation(200)
    sim.solver.rtol = 1e-10
    for f in range(3):
        sim.frame({"handle": flap_path((f + 1) / 30)})
    np.testing.assert_allclose(sim.u, u_ex43, atol=1e-8 * np.max(np.abs(u_ex43)))
    assert np.all(iterations >= 2)


def test_bad_benchmark_settings_are_rejected():
    with pytest.raises(ValueError, match="frames"):
        realtime_benchmark(sizes=(100,), frames=0, progress=None)
    with pytest.raises(ValueError, match="sizes"):
        realtime_benchmark(sizes=(), progress=None)


def test_cli_runs_the_realtime_benchmark(tmp_path, capsys):
    code = main(["bench", "realtime", "--sizes", "120", "--frames", "2", "--baseline-frames", "1",
                 "--out", str(tmp_path)])
    assert code == 0
    assert (tmp_path / "realtime.json").exists()
    # the command line draws the benchmark's figure from its results (the benchmark itself never draws)
    assert (tmp_path / "realtime.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    out = capsys.readouterr().out
    assert "median [ms]" in out and "min J" in out and "in budget: left undone" in out


@pytest.mark.parametrize("linear", ["superlu", "cg", "cg-jacobi"])
def test_the_frame_floor_is_measured_for_every_kind_of_solver(linear):
    """The floor applies what a frame applies: a factorization's back-substitution, a preconditioner, or (plain
    CG, no preconditioner) the iterative solve itself."""
    from tissuefem.workbook.bench.realtime import frame_floor

    floor = frame_floor(flap_simulation(200, linear), repeats=1)
    assert floor["floor_ms"] > 0 and floor["matrix_nnz"] > 0
