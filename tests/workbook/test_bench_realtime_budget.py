"""The frame-rate benchmark's budgeted columns on a tiny run (no timing is asserted)."""

import math

from tissuefem.workbook.bench.realtime import format_realtime_table, realtime_benchmark


def test_budgeted_frames_report_their_p99_beside_the_p95_and_the_unconverged_residuals():
    rows = realtime_benchmark(sizes=(150,), frames=2, baseline_frames=0, budget_frames=5, progress=None)
    row = rows[0]
    assert len(row["budget_frame_ms"]) == 5
    assert row["budget_p95_ms"] <= row["budget_p99_ms"] <= max(row["budget_frame_ms"])
    assert len(row["budget_unconverged_residuals"]) == round(5 * (1 - row["budget_converged"]))
    assert (math.isnan(row["budget_unconverged_residual"]) if not row["budget_unconverged_residuals"]
            else row["budget_unconverged_residual"] == max(row["budget_unconverged_residuals"]))
    header = format_realtime_table(rows).splitlines()[0]
    assert "| in budget: p95 [ms] | in budget: p99 [ms] |" in header
    assert "| in budget: worst unconverged rel. residual |" in header
