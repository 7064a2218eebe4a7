"""Chapter 10's figures (cutting through elements, flaps): each regenerates byte for byte, and what they show holds."""

import numpy as np
import pytest

from helpers import assert_figure_deterministic
from tissuefem.workbook import figures
from tissuefem.workbook.procedures import CRACK_MESHES, crack_opening, crack_runs, fold_run, overlap_area, pressed_cut_run
from tissuefem.surgery.element_cuts import picture

CHAPTER_10 = ["fig_ch10_virtual_nodes", "fig_ch10_cut_through", "fig_ch10_flaps", "fig_ch10_contact"]


def test_the_chapter_10_figures_are_registered():
    assert set(CHAPTER_10) <= set(figures.FIGURES)


@pytest.mark.parametrize("name", CHAPTER_10)
def test_chapter_10_figure_is_deterministic(name, tmp_path):
    assert_figure_deterministic(name, tmp_path)


def test_the_crack_opens_alike_on_both_meshes_only_when_cut_through_elements():
    runs = crack_runs()
    through = [crack_opening(*runs[("elements", n)]) for n in CRACK_MESHES]
    snapped = [crack_opening(*runs[("edges", n)]) for n in CRACK_MESHES]
    # measured: 0.1060 / 0.1061 through the elements (with the ghost penalty), 0.1064 / 0.1109 snapped to edges
    assert through[1] == pytest.approx(through[0], rel=0.01)
    assert abs(snapped[1] - snapped[0]) > 5 * abs(through[1] - through[0])


@pytest.mark.parametrize("run", [fold_run, pressed_cut_run], ids=["fold", "pressed-cut"])
def test_without_contact_the_body_overlaps_itself_and_with_it_only_within_the_skin(run):
    mesh, regions, free, u_free = run(False)
    _, _, held, u_held = run(True)
    drawn = picture(mesh, regions)
    skin = held.contact.distance
    a, b = held.contact.surface.segments
    y = held.contact.surface.positions(held.positions(u_held))
    surface_length = float(np.hypot(*(y[:, b] - y[:, a])).sum())
    without, with_contact = overlap_area(drawn, free.positions(u_free)), overlap_area(drawn, held.positions(u_held))
    assert with_contact <= 0.5 * skin * surface_length  # only a skin deep, on part of the surface
    assert without > 10 * with_contact
    assert 0 < held.contact.overlap(u_held) < skin
