"""The cut-frame comparison of ``bench scenes`` runs and reports its fields (no time is checked)."""

from tissuefem.workbook.bench import scenes


def test_cut_frame_costs_compare_a_kept_and_a_fresh_factorization():
    out = scenes.cut_frame_costs(400, repeats=1, frames_before=2)
    assert set(out) == {"kept", "fresh"}
    for row in out.values():
        assert {"cut_ms", "frame_ms", "total_ms", "spread_ms", "thread_ms", "factorizations"} <= set(row)
        assert row["total_ms"] > 0
    assert out["kept"]["factorizations"] == 0 and out["fresh"]["factorizations"] >= 1

