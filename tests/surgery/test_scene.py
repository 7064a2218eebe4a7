"""Scenes: files that round-trip, fields that are checked, and a model of exactly the named effects."""

import json

import numpy as np
import pytest

from tissuefem import Handle, Model, P1Assembler, RealtimeSolver, Scene, Simulation, StableNeoHookean, demo_scene, rectangle
from tissuefem.engine import effects as effects_module
from tissuefem.engine import terms as terms_module
from tissuefem.surgery.scene import EFFECTS, EXAMPLE_TOML


class FakeClock:
    def __init__(self):
        self.now = 0.0

    def __call__(self):
        return self.now


def sheet(**effects):
    """A small 2 x 1 sheet held on the left, with the given effects."""
    effects.setdefault("handles", [{"name": "fixed", "region": "left"},
                                   {"name": "pull", "region": {"box": [1.99, 0.0, 2.0, 1.0]}, "target": [0.2, 0.0]}])
    return {
        "name": "sheet",
        "domain": {"shape": "rectangle", "width": 2.0, "height": 1.0, "triangles": 160},
        "material": {"model": "stable-neo-hookean", "youngs_modulus": 1000.0, "poisson_ratio": 0.3},
        "effects": effects,
        "solver": {"budget": 1e9},
    }


def run(data, frames=4, **kwargs):
    sim = Simulation(Scene.from_dict(data), clock=FakeClock(), **kwargs)
    for _ in range(frames):
        sim.frame()
    return sim


# --- files ----------------------------------------------------------------------------------------------------

def test_example_scene_loads_and_round_trips_through_toml_and_json(tmp_path):
    scene = Scene.from_toml(EXAMPLE_TOML)
    assert scene.dynamic and set(scene.effects) == {"inertia", "gravity", "handles"}
    assert Scene.from_toml(scene.to_toml()) == scene
    assert Scene.from_json(scene.to_json()) == scene
    for name in ("s.toml", "s.json"):
        scene.save(tmp_path / name)
        assert Scene.load(tmp_path / name) == scene
    # the written TOML is the complete, normalised scene (defaults filled in)
    assert Scene.load(tmp_path / "s.toml").to_dict() == json.loads(scene.to_json())


def test_every_effect_round_trips():
    data = sheet(
        inertia={"time_step": 0.02, "mass": "consistent"},
        gravity={"acceleration": [0.0, -9.81]},
        fibers={"stiffness": 300.0, "direction": [1.0, 1.0]},
        inversion={"method": "projected"},
        tractions=[{"boundary": "top", "traction": [0.0, 5.0]}],
        probes=[{"center": [1.0, 1.2], "radius": 0.1, "stiffness": 1e5}],
        excisions=[{"polygon": [[0.8, 0.4], [1.0, 0.4], [1.0, 0.6], [0.8, 0.6]]}],
        incisions=[{"path": [[1.4, 0.0], [1.4, 0.5]]}],
        sutures=[{"pairs": [[[0.5, 1.0], [0.6, 1.0]]], "stiffness": 1e4, "tightness": 0.5}],
        contact={"distance": 0.01, "stiffness": 2e3},
    )
    scene = Scene.from_dict(data)
    assert set(scene.effects) == set(EFFECTS)
    assert Scene.from_toml(scene.to_toml()) == scene
    assert Scene.from_json(scene.to_json()) == scene


def test_a_users_mesh_file_is_read_through_meshio(tmp_path):
    mesh = rectangle(2.0, 1.0, 12, 6)
    mesh.save(str(tmp_path / "tissue.msh"))  # gmsh format, through meshio; named boundaries kept
    text = EXAMPLE_TOML.replace('shape = "rectangle"\nwidth = 2.0\nheight = 1.0\ntriangles = 800',
                                'shape = "file"\npath = "tissue.msh"')
    (tmp_path / "scene.toml").write_text(text)
    scene = Scene.load(tmp_path / "scene.toml")  # the path is relative to the scene file
    sim = Simulation(scene, clock=FakeClock())
    assert sim.mesh.nelements == mesh.nelements and sim.mesh.nvertices == mesh.nvertices
    assert np.allclose(sim.mesh.p, mesh.p)
    assert sim.frame().converged
    bad = Scene.from_toml(text.replace("tissue.msh", "missing.msh"), base_dir=tmp_path)
    with pytest.raises(ValueError, match="domain.path"):
        Simulation(bad)


# --- invalid scenes name the field ------------------------------------------------------------------------------

def _modified(change):
    data = sheet()
    change(data)
    return data


@pytest.mark.parametrize("change, field", [
    (lambda d: d["effects"].update(magnetism={}), "effects: unknown effect"),
    (lambda d: d.pop("material"), "material: missing"),
    (lambda d: d["material"].pop("youngs_modulus"), "material.youngs_modulus: missing"),
    (lambda d: d["material"].update(youngs_modulus=-5.0), "material.youngs_modulus must be > 0"),
    (lambda d: d["material"].update(youngs_modulus=float("nan")), "material.youngs_modulus must be finite"),
    (lambda d: d["material"].update(poisson_ratio=0.5), "material.poisson_ratio must be < 0.5"),
    (lambda d: d["material"].update(model="jelly"), "material.model must be one of"),
    (lambda d: d["material"].update(youngs_modulus="stiff"), "material.youngs_modulus must be a number"),
    (lambda d: d["domain"].update(shape="sphere"), "domain.shape must be one of"),
    (lambda d: d["domain"].update(triangles=10.5), "domain.triangles must be an integer"),
    (lambda d: d["domain"].update(colour="red"), "domain: unknown key"),
    (lambda d: d["effects"].update(inertia={"time_step": 0.0}), "effects.inertia.time_step must be > 0"),
    (lambda d: d["effects"].update(gravity={"acceleration": [0.0]}), "effects.gravity.acceleration must be a vector"),
    (lambda d: d["effects"].update(fibers={"direction": [1, 0]}), "effects.fibers.stiffness: missing"),
    (lambda d: d["effects"].update(inversion={"method": "magic"}), "effects.inversion.method must be one of"),
    (lambda d: d["effects"]["handles"][1].update(target=[0.0, float("inf")]), r"effects.handles\[1\].target\[1\]"),
    (lambda d: d["effects"]["handles"][0].pop("region"), r"effects.handles\[0\].region: missing"),
    (lambda d: d["effects"]["handles"][1].update(name="fixed"), "effects.handles: names must be unique"),
    (lambda d: d["effects"].update(probes=[{"center": [0, 0]}]), r"effects.probes\[0\].radius: missing"),
    (lambda d: d["effects"].update(incisions=[{"path": [[0, 0]]}]), r"effects.incisions\[0\].path"),
    (lambda d: d["effects"].update(sutures=[{"pairs": [[[0, 0]]]}]), r"effects.sutures\[0\].pairs\[0\]"),
    (lambda d: d["solver"].update(budget=-1), "solver.budget must be > 0"),
])
def test_invalid_scenes_are_rejected_naming_the_field(change, field):
    with pytest.raises(ValueError, match=field):
        Scene.from_dict(_modified(change))


@pytest.mark.parametrize("change, field", [
    (lambda d: d["effects"]["handles"][1].update(region={"box": [5.0, 5.0, 6.0, 6.0]}),
     r"effects.handles\[1\].region: selects no node of the mesh \(it lies outside the domain"),
    (lambda d: d["effects"]["handles"][1].update(region={"near": [-3.0, 0.5], "radius": 0.1}),
     r"effects.handles\[1\].region: selects no node"),
    (lambda d: d["effects"]["handles"][0].update(region="west"), r"effects.handles\[0\].region: 'west' is not a boundary"),
    (lambda d: d["effects"].update(tractions=[{"boundary": "north", "traction": [1, 0]}]), "effects.tractions"),
    (lambda d: d["effects"].update(inversion={"method": "itf"}), "effects.inversion.method: 'itf' clamps the ln J"),
    (lambda d: d["effects"].update(handles=[]), "effects.handles: a quasistatic scene needs"),
    (lambda d: d["effects"].update(fibers={"stiffness": 1.0, "direction": "fusiform"}), "effects.fibers.direction"),
])
def test_scenes_that_do_not_fit_their_mesh_are_rejected_when_built(change, field):
    scene = Scene.from_dict(_modified(change))  # well-formed ...
    with pytest.raises(ValueError, match=field):  # ... but not buildable
        Simulation(scene)


def test_bad_files_are_rejected(tmp_path):
    with pytest.raises(ValueError, match="not valid TOML"):
        Scene.from_toml("[domain\nshape = 1")
    with pytest.raises(ValueError, match="not valid JSON"):
        Scene.from_json("{")
    with pytest.raises(ValueError, match=r"\.toml or \.json"):
        Scene.load(tmp_path / "scene.yaml")


# --- only what is called for --------------------------------------------------------------------------------------

def test_the_model_lists_exactly_the_named_terms():
    plain = run(sheet(), frames=1)
    assert plain.terms == ["elastic"]
    assert plain.model.inertia is None  # quasistatic: no mass matrix is built
    full = run(sheet(inertia={}, gravity={}, fibers={"stiffness": 100.0},
                     tractions=[{"boundary": "top", "traction": [0.0, 1.0]}],
                     probes=[{"center": [1.0, 1.5], "radius": 0.2}]), frames=1)
    assert full.terms == ["inertia", "elastic", "fibers", "probe", "gravity", "tractions"]
    assert full.model.inertia is not None
    assert [type(t).__name__ for t in full.model.terms] == ["Inertia", "Elastic", "Fibers", "Probe", "Load", "Load"]


def test_an_absent_effect_is_never_evaluated(monkeypatch):
    def forbidden(*args, **kwargs):
        raise AssertionError("an absent effect was evaluated")

    for name in ("energy", "stress", "tangent"):
        monkeypatch.setattr(terms_module.FiberFamily, name, forbidden)
    monkeypatch.setattr(terms_module.Probe, "_contact", forbidden)
    monkeypatch.setattr(terms_module.Sutures, "_gap", forbidden)
    monkeypatch.setattr(effects_module, "traction_vector", forbidden)  # no traction
    monkeypatch.setattr(P1Assembler, "body_force", forbidden)  # no gravity
    monkeypatch.setattr(P1Assembler, "mass", forbidden)  # quasistatic: no mass matrix
    sim = run(sheet(), frames=3)
    assert sim.frame().converged


def _frames_of(data, frames=4):
    sim = run(data, frames=frames)
    return sim.u.copy()


@pytest.mark.parametrize("effect", [
    {"fibers": {"stiffness": 0.0}},
    {"gravity": {"acceleration": [0.0, 0.0]}},
    {"tractions": [{"boundary": "top", "traction": [0.0, 0.0]}]},
    {"probes": [{"center": [1.0, 0.5], "radius": 0.2, "stiffness": 0.0}]},
    {"sutures": [{"pairs": [[[0.5, 1.0], [1.5, 1.0]]], "stiffness": 1e-300, "tightness": 1.0}]},
])
@pytest.mark.parametrize("dynamic", [False, True], ids=["quasistatic", "dynamic"])
def test_an_effect_at_zero_magnitude_changes_nothing(effect, dynamic):
    base = sheet(**({"inertia": {}} if dynamic else {}))
    with_effect = sheet(**({"inertia": {}} if dynamic else {}), **effect)
    assert np.allclose(_frames_of(with_effect), _frames_of(base), rtol=0, atol=1e-10)


def test_a_linear_scene_factorises_once_and_each_frame_is_a_back_substitution():
    data = sheet()
    data["material"]["model"] = "linear"
    sim = Simulation(Scene.from_dict(data), clock=FakeClock())
    assert sim.solver.linear_solver_name == "constant-superlu" and sim.model.quadratic
    reports = [sim.frame({"pull": [0.01 * k, 0.005 * k]}) for k in range(1, 9)]
    assert sim.solver.linear.factorizations == 1
    assert [r.factorizations for r in reports] == [1] + [0] * 7
    # a quasistatic frame's linearised start is the whole (linear) solve: one Newton step, one back-substitution
    assert all(r.converged and r.newton_iterations == 1 for r in reports)
    # and it pays for one energy, two forces and no Hessian: one start is enough when one step from any is exact
    calls = {"energy": 0, "gradient": 0, "hessian": 0}
    for name in calls:
        def counted(*args, _name=name, _f=getattr(sim.model, name), **kwargs):
            calls[_name] += 1
            return _f(*args, **kwargs)
        setattr(sim.model, name, counted)
    assert sim.frame({"pull": [0.09, 0.045]}).converged
    assert calls == {"energy": 1, "gradient": 2, "hessian": 0}
    for name in calls:
        del sim.model.__dict__[name]
    sim.frame({"pull": [0.08, 0.04]})  # back where the general path below goes
    # the same frames through the general Newton path
    general = RealtimeSolver(Model(sim.mesh, sim.material, handles=[
        Handle(sim.handles["fixed"].nodes), Handle(sim.handles["pull"].nodes, [0.08, 0.04])]),
        linear_solver="reuse", budget=1e9, clock=FakeClock())
    general.frame()
    assert np.allclose(general.u, sim.u, rtol=0, atol=1e-8 * np.abs(sim.u).max())


def test_a_dynamic_linear_scene_also_uses_the_constant_factorisation():
    data = sheet(inertia={}, gravity={})
    data["material"]["model"] = "linear"
    sim = run(data, frames=10)
    assert sim.solver.linear_solver_name == "constant-superlu" and sim.solver.linear.factorizations == 1
    assert np.all(np.isfinite(sim.u)) and sim.u[1::2].min() < 0  # it sags under gravity


def test_a_nonlinear_or_probed_scene_uses_newton():
    assert run(sheet(), frames=1).solver.linear_solver_name.startswith("cg+reused")
    data = sheet(probes=[{"center": [1.0, 1.5], "radius": 0.2}])
    data["material"]["model"] = "linear"
    assert run(data, frames=1).solver.linear_solver_name.startswith("cg+reused")  # contact is not quadratic


def test_demo_scene_runs():
    sim = Simulation(demo_scene(200), clock=FakeClock())
    report = sim.frame()
    assert report.converged and sim.terms == ["inertia", "elastic"]


# --- the shipped scene files and the command ------------------------------------------------------------------

SCENES_DIR = __import__("pathlib").Path(__file__).resolve().parents[2] / "scenes"


@pytest.mark.parametrize("path", sorted(SCENES_DIR.glob("*.toml")), ids=lambda p: p.name)
def test_shipped_scene_files_load_round_trip_and_run(path):
    scene = Scene.load(path)
    assert Scene.from_toml(scene.to_toml()) == scene
    sim = Simulation(scene, clock=FakeClock())
    reports = sim.run(3)
    assert all(r.converged for r in reports) and np.all(np.isfinite(sim.u))


def test_the_scene_command_checks_and_runs(tmp_path, capsys):
    from tissuefem.workbook.cli import main

    assert main(["scene", str(SCENES_DIR / "incision.toml"), "--frames", "2"]) == 0
    out = capsys.readouterr().out
    assert "terms ['elastic', 'ghost penalty']" in out and "2 frames" in out  # cut through elements at the start
    bad = tmp_path / "bad.toml"
    bad.write_text(EXAMPLE_TOML.replace("poisson_ratio = 0.3", "poisson_ratio = 0.7"))
    assert main(["scene", str(bad), "--check"]) == 2
    assert "material.poisson_ratio" in capsys.readouterr().err


@pytest.mark.parametrize("key", [".".join(["x"] * 100_000), ".".join(['"a"'] * 100_000),
                                 "[" + " . ".join(["'b'"] * 30_000) + "]\nx"],
                         ids=["bare", "quoted", "header"])
def test_a_long_dotted_key_is_refused_before_parsing(key, monkeypatch):
    """tomllib's memory grows with the square of a key path's parts: the text is scanned first, and the parser
    never sees it."""
    import tomllib

    def parser_reached(text):
        raise AssertionError("the TOML parser was given a key path over the limit")

    monkeypatch.setattr(tomllib, "loads", parser_reached)
    with pytest.raises(ValueError, match=r"scene: a key path of (100000|30000) parts \(line \d\) is "
                                         r"longer than the limit of 16") as refused:
        Scene.from_toml(f"name = 'long'\n{key} = 1\n")
    assert refused.value.field == "scene"
    monkeypatch.undo()
    dotted = EXAMPLE_TOML.replace("[effects.inertia]\ntime_step", "[effects]\ninertia . 'time_step'")
    # dots in numbers, strings and short keys pass
    assert Scene.from_toml(dotted) == Scene.from_toml(EXAMPLE_TOML)


def test_a_list_field_may_be_a_numpy_array():
    """count_list asks a list's length, never its truth (a numpy array of two or more has none): node indices given
    as an array are checked like a list, and an empty array is refused naming the field."""
    data = sheet(handles=[{"name": "held", "region": {"nodes": np.array([0, 1, 2])}}])
    assert Scene.from_dict(data).effects["handles"][0]["region"]["nodes"] == [0, 1, 2]
    data["effects"]["handles"][0]["region"]["nodes"] = np.array([], dtype=int)
    with pytest.raises(ValueError, match="non-empty list") as refused:
        Scene.from_dict(data)
    assert refused.value.field == "effects.handles[0].region.nodes"
