"""Scenes in 3D: the block domain, 3D regions and vectors, a Simulation of tetrahedra, and what a 3D scene refuses."""

import contextlib
import io
import json

import numpy as np
import pytest

from tissuefem import Scene, Simulation
from tissuefem.engine.parameters import ParameterError
from tissuefem.surgery.scene import TWO_D_ONLY
from tissuefem.workbook import cli


class FakeClock:
    def __init__(self):
        self.now = 0.0

    def __call__(self):
        return self.now


def block(**effects):
    """A 2 x 1 x 1 block of tetrahedra held on its left face and pulled on its right face."""
    effects.setdefault("handles", [{"name": "fixed", "region": "left"},
                                   {"name": "pull", "region": {"box": [1.99, 0.0, 0.0, 2.0, 1.0, 1.0]},
                                    "target": [0.2, 0.0, 0.0]}])
    return {
        "name": "block",
        "domain": {"shape": "block", "lx": 2.0, "ly": 1.0, "lz": 1.0, "nx": 4, "ny": 2, "nz": 2},
        "material": {"model": "stable-neo-hookean", "youngs_modulus": 1000.0, "poisson_ratio": 0.3},
        "effects": effects,
        "solver": {"budget": 1e9},
    }


def run(data, frames=3):
    sim = Simulation(Scene.from_dict(data), clock=FakeClock())
    for _ in range(frames):
        sim.frame()
    return sim


# --- the block domain and its fields --------------------------------------------------------------------------

def test_a_block_scene_builds_a_box_of_tetrahedra_and_fills_3d_defaults():
    scene = Scene.from_dict(block(gravity={}, inertia={}))
    assert scene.dim == 3
    mesh = scene.build_mesh()
    assert mesh.p.shape[0] == 3 and mesh.nelements == 6 * 4 * 2 * 2
    assert scene.effects["gravity"]["acceleration"] == [0.0, -9.81, 0.0]
    assert scene.effects["handles"][0]["target"] == [0.0, 0.0, 0.0]
    assert Scene.from_dict({"domain": {"shape": "block"}, "material": block()["material"]}).domain == {
        "shape": "block", "lx": 1.0, "ly": 1.0, "lz": 1.0, "nx": 4, "ny": 4, "nz": 4}


def test_a_block_scene_round_trips_through_toml_and_json(tmp_path):
    scene = Scene.from_dict(block(inertia={"time_step": 0.02}, gravity={"acceleration": [0.0, 0.0, -9.81]},
                                  tractions=[{"boundary": "top", "traction": [0.0, -1.0, 0.0]}]))
    assert Scene.from_toml(scene.to_toml()) == scene and Scene.from_json(scene.to_json()) == scene
    for name in ("s.toml", "s.json"):
        scene.save(tmp_path / name)
        assert Scene.load(tmp_path / name) == scene
    assert Scene.load(tmp_path / "s.toml").to_dict() == json.loads(scene.to_json())


@pytest.mark.parametrize("change, field", [
    (lambda d: d["domain"].update(nx=100, ny=100, nz=100), "domain.nx"),
    (lambda d: d["domain"].update(nz=0), "domain.nz"),
    (lambda d: d["domain"].update(lz=1e-9), "domain.lz"),
    (lambda d: d["domain"].update(lx=1e5, lz=1e-3), "domain.lx"),
    (lambda d: d["domain"].update(width=2.0), "domain"),
    (lambda d: d["effects"]["handles"][1]["region"].update(box=[1.99, 0.0, 2.0, 1.0]),
     r"effects.handles\[1\].region.box"),
    (lambda d: d["effects"]["handles"][1]["region"].update(box=[2.0, 0.0, 0.0, 1.99, 1.0, 1.0]),
     r"effects.handles\[1\].region.box"),
    (lambda d: d["effects"]["handles"][1]["region"].update(box=[0.0, 0.0, 0.5, 1.0, 1.0, 0.4]),
     r"zmin <= zmax"),
    (lambda d: d["effects"]["handles"][1]["region"].update(box=[0.0, 0.0, 0.0, 1.0, 1.0, 1e6]),
     r"effects.handles\[1\].region.box\[3:6\]"),
    (lambda d: d["effects"]["handles"][1].update(target=[0.2, 0.0]), r"effects.handles\[1\].target"),
    (lambda d: d["effects"]["handles"][1].update(target=[0.2, 0.0, 1e9]), r"effects.handles\[1\].target"),
    (lambda d: d["effects"]["handles"][1].update(target=[0.2, 0.0, 0.0, 0.0]), r"effects.handles\[1\].target"),
    (lambda d: d["effects"]["handles"][1].update(region={"near": [2.0, 0.5], "radius": 0.2}),
     r"effects.handles\[1\].region.near"),
    (lambda d: d["effects"].update(gravity={"acceleration": [0.0, -9.81]}), "effects.gravity.acceleration"),
    (lambda d: d["effects"].update(tractions=[{"boundary": "top", "traction": [0.0, 1.0]}]),
     r"effects.tractions\[0\].traction"),
])
def test_a_3d_scene_refuses_fields_of_the_wrong_dimension_by_name(change, field):
    data = block()
    change(data)
    with pytest.raises(ParameterError, match=field):
        Scene.from_dict(data)


@pytest.mark.parametrize("kind, entry", [
    ("incisions", [{"path": [[0.5, 0.5], [1.0, 0.5]]}]),
    ("excisions", [{"polygon": [[0.5, 0.2], [1.0, 0.2], [1.0, 0.6]]}]),
    ("contact", {}),
])
def test_a_3d_scene_that_names_a_2d_only_effect_is_refused_saying_so(kind, entry):
    data = block(**{kind: entry})
    with pytest.raises(ParameterError, match=r"2D only for now") as err:
        Scene.from_dict(data)
    assert err.value.field == f"effects.{kind}" and kind in TWO_D_ONLY
    assert "3D" in str(err.value) and "block" in str(err.value)


def test_a_2d_scene_refuses_3d_vectors_by_name():
    data = block()
    data["domain"] = {"shape": "rectangle", "width": 2.0, "height": 1.0, "triangles": 60}
    with pytest.raises(ParameterError, match=r"effects.handles\[1\].region.box .*2D"):
        Scene.from_dict(data)
    data["effects"]["handles"][1] = {"name": "pull", "region": "right", "target": [0.1, 0.0, 0.0]}
    with pytest.raises(ParameterError, match=r"effects.handles\[1\].target .*3 components"):
        Scene.from_dict(data)


# --- a 3D simulation ------------------------------------------------------------------------------------------

def test_a_block_scene_runs_and_its_pulled_face_follows_its_target():
    sim = run(block(inertia={"time_step": 0.05}, gravity={}), frames=3)
    assert sim.frames == 3 and sim.model.dim == 3 and np.all(np.isfinite(sim.u))
    u = sim.u.reshape(-1, 3).T
    pulled, fixed = sim.handles["pull"].nodes, sim.handles["fixed"].nodes
    assert np.allclose(u[:, pulled], [[0.2], [0.0], [0.0]]) and np.allclose(u[:, fixed], 0.0)
    assert sim.pieces() == 1 and sim.positions().shape == (3, sim.mesh.nvertices)


def test_a_quasistatic_block_sags_under_gravity_and_a_traction():
    sim = run(block(gravity={}, tractions=[{"boundary": "top", "traction": [0.0, -5.0, 0.0]}],
                    handles=[{"name": "fixed", "region": {"box": [0.0, 0.0, 0.0, 0.0, 1.0, 1.0]}}]), frames=1)
    assert set(sim.terms) >= {"elastic", "gravity", "tractions"}
    u = sim.u.reshape(-1, 3).T
    tip = np.flatnonzero(np.isclose(sim.mesh.p[0], 2.0))
    assert np.all(u[1, tip] < 0) and np.allclose(u[:, sim.handles["fixed"].nodes], 0.0)


def test_a_3d_region_near_a_point_and_node_indices_select_nodes():
    data = block(inertia={}, handles=[{"name": "ball", "region": {"near": [2.0, 0.5, 0.5], "radius": 0.3}},
                                      {"name": "listed", "region": {"nodes": [0, 1]}}])
    sim = run(data, frames=1)
    ball = sim.handles["ball"].nodes
    assert ball.size >= 1 and np.all(np.linalg.norm(sim.mesh.p[:, ball] - [[2.0], [0.5], [0.5]], axis=0) <= 0.3)
    assert sim.handles["listed"].nodes.tolist() == [0, 1]


def test_grab_and_drag_move_a_3d_body_and_a_cut_is_refused_leaving_it_intact():
    sim = run(block(inertia={"time_step": 0.05}, handles=[{"name": "fixed", "region": "left"}]), frames=1)
    name = sim.grab([2.0, 0.5, 0.5], radius=0.6)
    nodes = sim.handles[name].nodes
    assert nodes.size == 6  # the grabbed node and its five neighbours half a cell away
    base = sim.u.reshape(-1, 3).T[:, nodes].copy()
    sim.drag(name, [2.0, 0.8, 0.5])
    sim.frame()
    assert np.allclose(sim.u.reshape(-1, 3).T[:, nodes], base + [[0.0], [0.3], [0.0]])
    with pytest.raises(ParameterError, match="point"):
        sim.drag(name, [2.0, 0.8])  # a 2D point for a 3D body
    frames, u = sim.frames, sim.u.copy()
    for operation in (lambda: sim.cut([[0.5, 0.5, 0.5], [1.0, 0.5, 0.5]]),
                      lambda: sim.excise([[0.5, 0.2], [1.0, 0.2], [1.0, 0.6]])):
        with pytest.raises(ParameterError, match="2D only"):
            operation()
    assert sim.frames == frames and np.array_equal(sim.u, u) and sim.mesh.p.shape[0] == 3
    sim.frame()
    assert sim.frames == frames + 1


def test_the_scene_command_runs_a_3d_scene_file(tmp_path):
    path = tmp_path / "block.toml"
    Scene.from_dict(block(inertia={}, gravity={})).save(path)
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        status = cli.main(["scene", str(path), "--frames", "2"])
    assert status == 0, err.getvalue()
    assert "96 tetrahedra" in out.getvalue() and "state finite: True" in out.getvalue()
