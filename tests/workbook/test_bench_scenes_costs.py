"""The cut-frame and probe comparisons of ``bench scenes`` run and report their fields (no time is checked)."""

from tissuefem.workbook.bench import scenes


def test_cut_frame_costs_compare_a_kept_and_a_fresh_factorization():
    out = scenes.cut_frame_costs(400, repeats=1, frames_before=2)
    assert set(out) == {"kept", "fresh"}
    for row in out.values():
        assert {"cut_ms", "frame_ms", "total_ms", "spread_ms", "thread_ms", "factorizations"} <= set(row)
        assert row["total_ms"] > 0
    assert out["kept"]["factorizations"] == 0 and out["fresh"]["factorizations"] >= 1


def test_probe_costs_report_newton_cg_and_updates_per_rank():
    out = scenes.probe_costs(400, frames=3, repeats=1, ranks=(0, 8))
    assert set(out) == {0, 8} and out[0]["updates"] == 0
    for row in out.values():
        assert set(row) == {"ms", "newton", "cg", "updates"} and row["newton"] >= 1
