"""The haptic benchmark's code paths on a tiny run, and the force error it measures (no timing is asserted)."""

import csv
import json
import time

import numpy as np
import pytest

from helpers import assert_figure_deterministic
from tissuefem import flap_path
from tissuefem.engine.haptics import ToolModel
from tissuefem.workbook.bench.haptic import HapticLoop, format_haptic_table, haptic_benchmark, haptic_path
from tissuefem.workbook.cli import main


def test_tiny_benchmark_writes_json_and_csv(tmp_path):
    record = haptic_benchmark(n_triangles=200, frames=3, path_frames=2, substeps=2, out=tmp_path, progress=None)
    saved = json.loads((tmp_path / "haptic.json").read_text())
    assert saved["benchmark"] == "haptic" and "scikit-fem" in saved["machine"]
    row = saved["rows"][0]
    assert row["triangles"] == record["rows"][0]["triangles"] and row["frames"] == 3
    assert len(row["frame_plain_ms"]) == len(row["frame_haptic_ms"]) == len(row["build_ms"]) == 3
    assert row["updates"] > 0 and row["updates_per_second"] > 0 and row["update_median_us"] > 0
    assert row["missed_ticks"] >= 0 and 0 <= row["late_median_us"] <= row["late_p95_us"] <= row["late_max_us"]
    assert 0 <= row["haptic_error_median"] <= row["haptic_error_max"]
    assert len(saved["path"]["time"]) == 2 * 2
    with open(tmp_path / "haptic.csv", newline="") as fh:
        table = list(csv.DictReader(fh))
    assert len(table) == 1 and "updates_per_second" in table[0] and "build_ms" not in table[0]
    text = format_haptic_table(record["rows"])
    assert text.count("\n") == 2 and "| updates/s |" in text


def test_the_reduced_force_follows_the_converged_frames_far_better_than_the_held_force():
    run = haptic_path(n_triangles=300, frames=4, substeps=4, warmup=3)
    assert run["time"].shape == (16,) and run["haptic"].shape == run["converged"].shape == (16, 2)
    # the tool's positions lie on the scripted drag, after each frame on to the next
    np.testing.assert_allclose(run["position"], [flap_path(t) for t in run["time"]])
    np.testing.assert_allclose(run["time"][3::4], run["frame_time"] + 1 / 30)
    assert np.all(run["haptic_error"] < 0.02)
    assert np.median(run["haptic_error"]) < 0.1 * np.median(run["hold_error"])
    # exact to first order: the error grows about like the square of the distance moved since the frame
    errors = run["haptic_error"].reshape(4, 4)
    assert np.all(errors[:, 3] > errors[:, 0])
    assert run["jump"].shape == (3,) and np.all(np.isfinite(run["jump"]))


def test_the_loop_updates_while_active_and_stops():
    model = ToolModel("handle", "handle", np.zeros(2), np.array([1.0, 0.0]), np.eye(2), 1)
    with HapticLoop(lambda: model, lambda: np.array([0.5, 0.5]), rate=2000.0) as loop:
        loop.resume()
        time.sleep(0.05)
        loop.pause()
    assert not loop.thread.is_alive()
    assert len(loop.update_seconds) == len(loop.lateness) > 0 and loop.active_seconds > 0
    np.testing.assert_allclose(loop.last_force, [1.5, 0.5])
    # a position the model refuses (a device's glitch) keeps the last force and the loop running
    positions = iter([np.array([0.5, 0.5])] + [np.array([np.nan, 0.0])] * 1_000_000)
    with HapticLoop(lambda: model, lambda: next(positions), rate=2000.0) as loop:
        loop.resume()
        time.sleep(0.02)
        loop.pause()
    assert loop.refused > 0 and len(loop.update_seconds) > loop.refused
    np.testing.assert_allclose(loop.last_force, [1.5, 0.5])


class FakeClock:
    """Time that passes only when the loop sleeps (``sleep(0)``: a yield, 10 µs) or an update says so."""

    def __init__(self):
        self.now = 100.0

    def __call__(self):
        return self.now

    def sleep(self, seconds):
        assert seconds >= 0
        self.now += max(seconds, 1e-5)


def test_a_late_tick_runs_at_once_and_the_ticks_keep_their_times():
    clock, model = FakeClock(), ToolModel("handle", "handle", np.zeros(2), np.zeros(2), np.eye(2), 1)
    loop = HapticLoop(lambda: model, lambda: position(), rate=1000.0, clock=clock, sleep=clock.sleep)

    def position():  # each update takes 0.1 ms, the fourth 3.5 ms (the frames held the interpreter); pause after ten
        clock.now += 3.5e-3 if len(loop.lateness) == 4 else 1e-4
        if len(loop.lateness) == 10:
            loop.pause()
        return np.zeros(2)

    loop.resume()
    began = clock.now
    loop.ticking()
    late = np.array(loop.lateness)
    assert late.shape == (10,) and loop.refused == 0
    # the next three were due while the fourth ran: run at once, late by 2.5, 1.6 and 0.7 ms, none dropped
    np.testing.assert_allclose(late[4:7], [2.5e-3, 1.6e-3, 0.7e-3], atol=1e-9)
    assert np.sum(late >= loop.period) == 2  # missed: late by a period or more
    # the others start on time (within a yield): the schedule did not drift behind the late ones
    assert np.all(np.delete(late, [4, 5, 6]) < 2e-5)
    np.testing.assert_allclose(loop.active_seconds, clock.now - began, atol=1.1e-3)
    assert len(loop.update_seconds) / loop.active_seconds >= 1000.0


@pytest.mark.parametrize("argv", [["bench", "haptic", "--sizes", "200", "300"], ["bench", "haptic", "--sizes", "20"]])
def test_the_cli_refuses_sizes_by_name(argv, capsys):
    with pytest.raises(SystemExit) as err:
        main(argv)
    assert err.value.code == 2 and "sizes" in capsys.readouterr().err


def test_the_haptic_figure_is_deterministic(tmp_path):
    assert_figure_deterministic("fig_ch08_haptic_force", tmp_path)
