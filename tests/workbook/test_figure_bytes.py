"""What keeps a regenerated figure's bytes unchanged on another machine: whole pixels, data
rounded to what a figure can show, and labels that do not print round-off."""

import math

import matplotlib
import numpy as np

from tissuefem.workbook.figures import base as registry


def test_a_size_of_whole_pixels_is_whole_however_it_is_truncated():
    # 4.6 in x 110 dpi = 505.99999999999994 px: truncated by matplotlib 3.11.0, rounded by 3.11.2
    assert math.floor(4.6 * 110) == 505
    size = registry.whole_pixels(4.6)
    assert math.floor(size * 110) == 506 and math.floor(size * 110 + 1e-8) == 506
    assert abs(size - 4.6) < 1e-14
    for inches in (6.4, 9.0, 10.75, 3.7):  # exact products and half pixels are left alone
        assert registry.whole_pixels(inches) == inches


def test_shown_rounds_away_round_off_and_floors_it():
    a = np.array([1.2345678e-9, 1.2345679e-9 * (1 + 1e-12), 3e-14, 0.0, np.inf])
    out = registry.shown(a, floor=1e-12)
    np.testing.assert_array_equal(out[:2], [1.23e-9, 1.23e-9])
    assert out[2] == 1e-12 and out[3] == 1e-12 and np.isinf(out[4])
    assert registry.shown([8.4197e-10], digits=2)[0] == 8.4e-10


def test_labels_do_not_print_round_off():
    assert registry.at_least(2.1e-17) == "< 1e-10" and registry.at_least(3.3e-12) == "< 1e-10"
    assert registry.at_least(2.1e-17, 1e-9) == "< 1e-9"
    assert registry.at_least(0.034) == "0.034" and registry.at_least(1.7e-3, spec=".1e") == "1.7e-03"


def test_a_note_when_matplotlib_would_redraw_the_text(monkeypatch):
    monkeypatch.setattr(matplotlib, "__version__", registry.FIGURES_MATPLOTLIB + ".7")
    assert registry.matplotlib_note() is None
    monkeypatch.setattr(matplotlib, "__version__", "3.9.4")
    assert "every PNG in figures/ will change" in registry.matplotlib_note()
