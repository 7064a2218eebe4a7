"""The registry of effects: a new effect is its term and one entry; a scene builds one model however many probes
and sutures it gains; a model carries itself across a cut."""

import numpy as np
import pytest

from tissuefem.engine import effects, parameters
from tissuefem.engine import model as model_module
from tissuefem.engine.meshes import rectangle
from tissuefem.engine.materials import material
from tissuefem.engine.model import Handle, Model
from tissuefem.engine.parameters import ParameterError
from tissuefem.engine.stepping import Stepper
from tissuefem.engine.terms import Load
from tissuefem.surgery.element_cuts import cut_through
from tissuefem.surgery.scene import Scene
from tissuefem.surgery.simulation import Simulation

def _scene(**more):
    return Scene(domain={"shape": "rectangle", "width": 2.0, "height": 1.0, "triangles": 200},
                 material={"model": "stable-neo-hookean", "youngs_modulus": 1000.0, "poisson_ratio": 0.3},
                 effects={"handles": [{"name": "fixed", "region": "left"}], "inertia": {}, **more},
                 solver={"budget": 1e9})

def test_a_new_effect_is_its_term_and_one_registry_entry():
    """A constant wind, a body force per unit area: the term is a Load, the entry checks the table and makes it."""
    saved = dict(effects.EFFECTS)  # registered for this test only
    try:
        _run_a_windy_scene()
    finally:
        effects.EFFECTS.clear()
        effects.EFFECTS.update(saved)


def _run_a_windy_scene():

    def check(field, entry):
        entry = parameters.table(field, entry, ("force",))
        return {"force": parameters.vector(f"{field}.force", entry.get("force", [1.0, 0.0]), 1e6)}

    def build(model, params, scene):
        def make(m):
            return m.assembler.body_force(np.asarray(params["force"]))
        return Load("wind", make(model), make)

    effects.register("wind", check, build)
    scene = _scene(wind={"force": [50.0, 0.0]})
    assert Scene.from_toml(scene.to_toml()) == scene
    sim = Simulation(scene, clock=lambda: 0.0)
    assert sim.terms[-1] == "wind"
    sim.run(3)
    assert sim.positions()[0].max() > 2.0  # blown to the right
    sim.cut([[1.0, -0.1], [1.0, 0.5]])  # a cut carries the wind to the new mesh
    assert "wind" in sim.terms and sim.frame().converged
    with pytest.raises(ParameterError, match=r"effects.wind.force\[0\]"):
        _scene(wind={"force": ["east", 0.0]})

def test_a_scene_builds_one_model_however_many_probes_and_sutures(monkeypatch):
    built = []
    original = model_module.Model.__init__

    def counting(self, *args, **kwargs):
        built.append(self)
        original(self, *args, **kwargs)

    monkeypatch.setattr(model_module.Model, "__init__", counting)
    scene = _scene(probes=[{"center": [0.5, 1.2], "radius": 0.25}, {"center": [1.5, 1.2], "radius": 0.25}],
                   sutures=[{"pairs": [[[1.9, 0.2], [1.9, 0.8]]], "tightness": 0.5}])
    sim = Simulation(scene, clock=lambda: 0.0)
    sim.add_probe([1.0, 1.3], 0.2)
    sim.suture([[[1.8, 0.1], [1.8, 0.9]]])
    sim.run(2)
    assert len(built) == 1 and sim.model is built[0]
    assert [t.name for t in sim.model.terms] == ["inertia", "elastic", "probe", "probe", "probe", "sutures"]
    assert sim.model.sutures.k.size == 2

def test_a_model_carries_its_terms_handles_and_state_across_a_cut():
    mesh = rectangle(2.0, 1.0, 16, 8)
    model = Model(mesh, material("stable-neo-hookean", 1000.0, 0.3), dt=0.05, gravity=(0.0, -9.81),
                  probes=[dict(center=(1.5, 1.2), radius=0.3, stiffness=1e4)],
                  handles=[Handle("left"), Handle("right", (0.1, 0.0), name="pull")])
    stepper = Stepper(model)
    stepper.step()
    edit = cut_through(mesh, [[1.0, -0.1], [1.0, 0.6]], model.positions(stepper.u))
    new, (u, v) = model.remapped(edit, (stepper.u, stepper.v))
    # the cut adds the ghost penalty that holds its pieces' virtual nodes (engine.terms.GhostPenalty)
    assert [name for name in new.term_names if name != "ghost penalty"] == model.term_names
    assert "ghost penalty" in new.term_names and [h.name for h in new.handles] == ["handle0", "pull"]
    assert u.shape == (new.n_dofs,) and np.array_equal(new.positions(u)[:, : mesh.nvertices], model.positions(stepper.u))
    after = Stepper(new)
    after.set_state(u, v)
    assert after.step().converged
