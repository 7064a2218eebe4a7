"""Chapter 8's figures (virtual surgery): each regenerates byte for byte, and the animation is written too."""

import numpy as np
import pytest

from helpers import assert_figure_deterministic
from tissuefem.workbook import figures
from tissuefem.workbook.procedures import FALL_FRAMES, SAG_FRAMES, two_pieces_run

CHAPTER_8 = ["fig_ch08_incision", "fig_ch08_two_pieces", "fig_ch08_probe", "fig_ch08_flap"]


def test_the_chapter_8_figures_are_registered():
    assert set(CHAPTER_8) <= set(figures.FIGURES)


@pytest.mark.parametrize("name", CHAPTER_8)
def test_chapter_8_figure_is_deterministic(name, tmp_path):
    assert_figure_deterministic(name, tmp_path)
    if name == "fig_ch08_two_pieces":
        from PIL import Image

        from tissuefem.workbook.figures.base import ANIMATION_MIN_WIDTH

        gifs = [tmp_path / d / f"{name}.gif" for d in "ab"]
        data = gifs[0].read_bytes()
        assert data[:6] == b"GIF89a"
        # the same frames give the same bytes: the helper compared the GIF with the committed one (with
        # another matplotlib, with a second run's)
        assert not gifs[1].exists() or data == gifs[1].read_bytes()
        with Image.open(gifs[0]) as im:
            assert im.n_frames == SAG_FRAMES + FALL_FRAMES + 1
            assert im.size[0] >= ANIMATION_MIN_WIDTH  # large enough to project
        assert len(data) < 500_000  # projectable size, still small for the repository


def test_without_a_path_nothing_is_written(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert figures.FIGURES["fig_ch08_two_pieces"]() is not None
    assert not list(tmp_path.iterdir())


def test_the_free_piece_falls_freely_and_the_held_one_hangs():
    run = two_pieces_run(n_triangles=300, sag_frames=6, fall_frames=8)
    com, cut = run["com"], run["cut_frame"]
    # its internal forces cancel: the centre of mass follows backward Euler's discrete free fall
    np.testing.assert_allclose(com[cut:, 1], run["free_fall"], rtol=0, atol=1e-8)
    assert com[-1, 1] < com[cut, 1] - 0.2 and abs(com[-1, 0] - com[cut, 0]) < 0.1
    assert run["simulation"].pieces() == 2
