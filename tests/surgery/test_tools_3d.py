"""The surgical tools on a 3D scene (a block of tetrahedra): a probe pressed, moved and removed, stitches between
nodes tightened; stitches placed at points (finding the element there) stay 2D only and are refused by name.

The engine's terms are checked in tests/engine/test_terms_3d.py; here the simulation's path to them.
"""

import numpy as np
import pytest

from tissuefem import Scene, Simulation
from tissuefem.engine.parameters import ParameterError

E = 1000.0


def _block_simulation(**effects):
    """A 1 x 0.5 x 0.5 block held on its bottom face (3D scenes: the ``block`` domain)."""
    try:
        scene = Scene.from_dict({
            "domain": {"shape": "block", "lx": 1.0, "ly": 0.5, "lz": 0.5, "nx": 4, "ny": 2, "nz": 2},
            "material": {"model": "stable-neo-hookean", "youngs_modulus": E, "poisson_ratio": 0.3},
            "effects": {"handles": [{"name": "fixed", "region": "bottom"}], **effects},
            "solver": {"budget": 1e9}})
    except ParameterError as err:
        if "domain.shape" in str(err):
            pytest.skip("this tree's scenes have no 3D domain")
        raise
    return Simulation(scene, clock=lambda: 0.0)


def test_a_probe_presses_a_3d_scene_moves_and_goes():
    sim = _block_simulation()
    assert sim.model.dim == 3
    label = sim.add_probe([0.5, 0.5 + 0.2 - 0.02, 0.25], 0.2)  # a ball pressed 0.02 into the top face
    probe = sim.model.probes[0]
    assert probe.describe().startswith("probe: ball r = 0.2 at (0.5, 0.68, 0.25)")
    assert probe.stiffness == pytest.approx(100.0 * E / 0.2)  # the default: 100 E / radius
    sim.frame()
    x = sim.positions()
    assert np.all(np.isfinite(x)) and x[1].min() > -1e-9  # held on the bottom
    assert x[1, np.isclose(sim.mesh.p[0], 0.5) & np.isclose(sim.mesh.p[1], 0.5)].min() < 0.5  # pressed down
    sim.move_probe(label, [0.25, 0.7, 0.25])
    assert sim.model.probes[0].center.tolist() == [0.25, 0.7, 0.25]
    with pytest.raises(ParameterError, match=r"center must be a finite vector \(x, y, z\)"):
        sim.move_probe(label, [0.25, 0.7])
    with pytest.raises(ParameterError, match=r"probe.center must be a finite vector \(x, y, z\)"):
        sim.add_probe([0.5, 0.7], 0.2)
    sim.remove_probe(label)
    assert sim.model.probes == []
    sim.frame()


def test_a_3d_scene_names_its_probes():
    sim = _block_simulation(probes=[{"center": [0.5, 0.68, 0.25], "radius": 0.2}])
    assert [p.label for p in sim.model.probes] == ["probe1"]
    sim.frame()
    assert sim.model.probes[0].penetration(sim.solver.u) > 0


def test_stitches_between_nodes_of_a_3d_scene_pull_them_together():
    sim = _block_simulation()
    p = sim.mesh.p
    a = int(np.flatnonzero(np.all(np.isclose(p, [[0.0], [0.5], [0.0]]), axis=0))[0])
    b = int(np.flatnonzero(np.all(np.isclose(p, [[0.0], [0.5], [0.5]]), axis=0))[0])
    tied = sim.suture(np.array([[a], [b]]), tightness=0.0)
    assert tied.tolist() == [[a], [b]]
    assert sim.model.sutures.coefficients.shape == (2, 4, 1)  # an end: a corner of a tetrahedron
    gap = sim.suture_gaps()[0]
    assert gap == pytest.approx(0.5)
    for s in (0.1, 0.2):
        sim.tighten(s)
        sim.frame()
    assert 0.75 * gap < sim.suture_gaps()[0] < 0.85 * gap
    with pytest.raises(ParameterError, match=r"sutures.pairs: stitches at points are 2D only.*node index pairs"):
        sim.suture([[[0.0, 0.5, 0.0], [0.0, 0.5, 0.5]]])
    assert sim.model.sutures.k.size == 1  # a refusal keeps the stitches as they were
