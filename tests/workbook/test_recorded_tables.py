"""docs/benchmarks.md and chapter 7 print their tables from the recorded runs shipped with the package: the page
must show exactly what the record gives, so a re-recording cannot leave a stale table behind."""

from pathlib import Path

import pytest

from tissuefem.workbook.bench.accuracy_cost import format_knob_table, recorded_results
from tissuefem.workbook.bench.common import median_rows, recorded
from tissuefem.workbook.bench.realtime import recorded_realtime, recorded_realtime_table
from tissuefem.workbook.bench.scenes import recorded_effects, recorded_effects_table

DOC = Path(__file__).parents[2] / "docs" / "benchmarks.md"

#: the settings docs/benchmarks.md shows from the accuracy study: (benchmark, knob, value)
SELECTION = [("block", "mesh", 8000), ("block", "mesh", 32000), ("block", "P2", 2000), ("block", "P2", 4000),
             ("block", "newton_tolerance", 0.001), ("block", "newton_cap", 1), ("block", "material", "linear"),
             ("block", "material", "stable-neo-hookean"), ("block", "material", "corotated"),
             ("flap", "mesh", 8000), ("flap", "mesh", 500), ("flap", "mesh", 32000), ("flap", "time_step", 2),
             ("flap", "time_step", 4), ("flap", "linear_solver", "direct"), ("flap", "linear_solver", "superlu-colamd"),
             ("flap", "linear_solver", "cg-jacobi"), ("flap", "linear_solver", "cg-ilu")]


def accuracy_table() -> str:
    rows = recorded_results()["knobs"]
    return format_knob_table([next(r for r in rows if (r["benchmark"], r["knob"], r["value"]) == key)
                              for key in SELECTION])


@pytest.mark.parametrize("table", [recorded_realtime_table, recorded_effects_table, accuracy_table])
def test_the_page_shows_the_recorded_tables(table):
    assert table() in DOC.read_text(encoding="utf-8"), f"docs/benchmarks.md does not show {table.__name__}()"


def test_the_records_say_when_and_how_quiet():
    for name in ("realtime", "scenes"):
        record = recorded(name)
        assert len(record["rounds"]) >= 2 and record["date"] and record["load_before"] < 1.0, name
        for r in record["rounds"]:
            assert len(r["machine"]["load_average"]) == 3, name
    conditions = recorded_results()["conditions"]
    assert conditions["quiet"] and conditions["date"]


def test_median_rows_takes_the_median_over_rounds_and_keeps_the_range():
    rows = median_rows([[{"n": 1, "ms": 3.0, "k": 2}], [{"n": 1, "ms": 5.0, "k": 2}], [{"n": 1, "ms": 4.0, "k": 2}]], "n")
    assert rows == [{"n": 1, "ms": 4.0, "ms_range": (3.0, 5.0), "k": 2}]


def test_recorded_rows_carry_what_the_chapters_print():
    rows, _ = recorded_realtime()
    assert [r["triangles"] for r in rows] == sorted(r["triangles"] for r in rows)
    assert all("budget_p99_ms" in r and "speedup" in r for r in rows)
    effects, _ = recorded_effects()
    assert effects[0]["over_base"] == 1.0 and all(r["over_base"] > 0 for r in effects)


def browser_table() -> str:
    from tissuefem.workbook.tables import markdown_table
    rows = [{"run": i + 1, "nagle": "on" if run.get("kernel_websockets", "").startswith("Jupyter") else "off",
             "triangles": r["mesh"]["triangles"], "fps": r["dragging"]["painted_per_second"],
             "fps_first": r["dragging"]["painted_per_second_from_the_first_picture"],
             "step": r["dragging"]["kernel_step_median_ms"], "median": r["latency"]["median_ms"],
             "p95": r["latency"]["p95_ms"], "rest": r["at_rest"]["cpu_percent_of_a_core"]}
            for i, run in enumerate(recorded("browser_view")["rounds"]) for r in run["results"]]
    return markdown_table(rows, [("run", "run", "{:d}"), ("nagle", "Nagle on the kernel websocket", "{}"),
                                 ("triangles", "triangles", "{:d}"),
                                 ("fps", "pictures/s dragging", "{:.1f}"),
                                 ("fps_first", "pictures/s from the first picture", "{:.1f}"),
                                 ("step", "kernel step ms", "{:.1f}"),
                                 ("median", "mouse to picture median ms", "{:.0f}"),
                                 ("p95", "mouse to picture p95 ms", "{:.0f}"), ("rest", "kernel at rest % of a core", "{:.1f}")])


def test_the_page_shows_the_recorded_browser_runs():
    assert browser_table() in DOC.read_text(encoding="utf-8")


def realtime3d_table() -> str:
    from tissuefem.workbook.tables import markdown_table
    rows = recorded("realtime3d")["rounds"][0]["rows"]
    return markdown_table(rows, [("tetrahedra", "tetrahedra", "{:d}"), ("dofs", "dofs", "{:d}"),
                                 ("fast_median_ms", "median ms", "{:.1f}"), ("fast_p95_ms", "p95 ms", "{:.1f}"),
                                 ("fast_newton", "Newton/frame", "{:.2f}"), ("fast_cg", "CG/frame", "{:.1f}"),
                                 ("assembly_ms", "assembly ms", "{:.1f}"),
                                 ("back_substitution_ms", "back-substitution ms", "{:.2f}"),
                                 ("floor_ms", "floor ms", "{:.1f}"), ("fast_converged", "converged", "{:.0%}")])


def test_the_page_shows_the_recorded_3d_run():
    assert realtime3d_table() in DOC.read_text(encoding="utf-8")


def test_the_page_shows_the_recorded_haptic_run():
    from tissuefem.workbook.bench.haptic import format_haptic_table
    assert format_haptic_table(recorded("haptic")["rounds"][0]["rows"]) in DOC.read_text(encoding="utf-8")
