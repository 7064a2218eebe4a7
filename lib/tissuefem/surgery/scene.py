"""Scenes: a declarative description of a simulation, and the running simulation it builds.

A scene names a domain, a material and the *effects* it calls for, and
nothing else gets built:

================  =============================================================================
effect            what it adds
================  =============================================================================
``inertia``       dynamics: backward Euler with time step ``time_step`` (absent: quasistatic,
                  and no mass matrix is built)
``gravity``       the body force ``rho0 g`` (a constant load)
``fibers``        the fibre energy ``k/8 (I4 - 1)^2`` along ``direction``
``inversion``     inversion handling of the material: ``"itf"`` (ITF-clamped ln J) or
                  ``"projected"`` (PSD-projected tangent)
``handles``       nodes held or pulled (a boundary name, a box, or the nodes near a point)
``tractions``     a constant traction on a named boundary
``probes``        rigid disc tool tips pressed into the tissue (a penalty term)
``excisions``     defects removed (elements inside a polygon) before the first frame
``incisions``     cuts along polylines (duplicated nodes) before the first frame
``sutures``       pairs of points tied together by stiff springs
================  =============================================================================

A scene is a plain nested dictionary with these keys (see
:data:`EXAMPLE_TOML`), written in Python (:class:`Scene`), or loaded from a
TOML or JSON file (:meth:`Scene.load`). Every field is checked, and an invalid
scene raises ``ValueError`` naming the field (``effects.handles[1].region``).

:class:`Simulation` builds the scene (mesh, then excisions and incisions,
then the :class:`~tissuefem.model.Model` of exactly the named terms, then the
real-time solver) and offers the virtual-surgery operations between frames:
:meth:`~Simulation.grab`/:meth:`~Simulation.drag`/:meth:`~Simulation.release`,
:meth:`~Simulation.add_probe`, :meth:`~Simulation.cut`,
:meth:`~Simulation.excise` and :meth:`~Simulation.suture`. A topology change
(cut, excision) builds a new mesh and model and carries the state over
(displacement, velocity, time, frame count); nothing is lost.
"""

from __future__ import annotations

import contextlib
import copy
import dataclasses
import json
import math
import time
import tomllib
from pathlib import Path

import numpy as np
import skfem

from ..engine import meshes
from ..engine.materials import MATERIALS
from ..engine.materials import material as make_material
from ..engine.model import Model, NodeHandle, _vector2, load_vector
from ..engine.realtime import FRAME_BUDGET, ConstantTangentSolver, RealtimeSolver

__all__ = ["Scene", "Simulation", "EFFECTS", "SHAPES", "EXAMPLE_TOML", "demo_scene"]

#: the effects a scene may name
EFFECTS = ("inertia", "gravity", "fibers", "inversion", "handles", "tractions", "probes", "excisions",
           "incisions", "sutures")
#: the domains a scene may use ("file": a 2D triangle mesh read through meshio)
SHAPES = ("rectangle", "flap", "fusiform", "file")
#: the list-valued effects (each entry is a table)
_LISTS = ("handles", "tractions", "probes", "excisions", "incisions", "sutures")

EXAMPLE_TOML = """\
name = "pulled sheet"
description = "A sheet held on the left and pulled on the right, under gravity."

[domain]
shape = "rectangle"
width = 2.0
height = 1.0
triangles = 800

[material]
model = "stable-neo-hookean"
youngs_modulus = 1000.0
poisson_ratio = 0.3
density = 1.0

[effects.inertia]
time_step = 0.0333333

[effects.gravity]
acceleration = [0.0, -9.81]

[[effects.handles]]
name = "fixed"
region = "left"

[[effects.handles]]
name = "pull"
region = { box = [1.95, 0.0, 2.0, 1.0] }
target = [0.3, 0.0]

[solver]
budget = 0.0333333
"""


# ---------------------------------------------------------------------------------------------------------------
# checking fields
# ---------------------------------------------------------------------------------------------------------------

def _number(field, value, *, positive=False, nonnegative=False, integer=False, below=None):
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise ValueError(f"{field} must be a number, got {value!r}")
    v = float(value)
    if not math.isfinite(v):
        raise ValueError(f"{field} must be finite, got {value!r}")
    if positive and v <= 0:
        raise ValueError(f"{field} must be > 0, got {value!r}")
    if nonnegative and v < 0:
        raise ValueError(f"{field} must be >= 0, got {value!r}")
    if below is not None and v >= below:
        raise ValueError(f"{field} must be < {below}, got {value!r}")
    if integer:
        if v != int(v):
            raise ValueError(f"{field} must be an integer, got {value!r}")
        return int(v)
    return v


def _vector(field, value):
    if not isinstance(value, (list, tuple, np.ndarray)) or len(value) != 2:
        raise ValueError(f"{field} must be a vector [x, y], got {value!r}")
    return [_number(f"{field}[{i}]", c) for i, c in enumerate(value)]


def _points(field, value, minimum):
    if not isinstance(value, (list, tuple, np.ndarray)) or len(value) < minimum:
        raise ValueError(f"{field} must be a list of at least {minimum} points [x, y], got {value!r}")
    return [_vector(f"{field}[{i}]", p) for i, p in enumerate(value)]


def _table(field, value):
    if not isinstance(value, dict):
        raise ValueError(f"{field} must be a table (a dict), got {value!r}")
    return value


def _only(field, table, allowed):
    unknown = sorted(set(table) - set(allowed))
    if unknown:
        raise ValueError(f"{field}: unknown key(s) {unknown}; allowed: {sorted(allowed)}")


def _string(field, value, choices=None):
    if not isinstance(value, str):
        raise ValueError(f"{field} must be a string, got {value!r}")
    if choices is not None and value not in choices:
        raise ValueError(f"{field} must be one of {list(choices)}, got {value!r}")
    return value


def _check_domain(d):
    d = _table("domain", d)
    shape = _string("domain.shape", d.get("shape", "rectangle"), SHAPES)
    out = {"shape": shape}
    if shape in ("rectangle", "flap"):
        _only("domain", d, ("shape", "width", "height", "triangles"))
        out["width"] = _number("domain.width", d.get("width", 2.0 if shape == "flap" else 1.0), positive=True)
        out["height"] = _number("domain.height", d.get("height", 1.0), positive=True)
        out["triangles"] = _number("domain.triangles", d.get("triangles", 800), positive=True, integer=True)
    elif shape == "fusiform":
        _only("domain", d, ("shape", "length", "max_width", "tendon_width", "nx", "ny"))
        out["length"] = _number("domain.length", d.get("length", 4.0), positive=True)
        out["max_width"] = _number("domain.max_width", d.get("max_width", 1.0), positive=True)
        out["tendon_width"] = _number("domain.tendon_width", d.get("tendon_width", 0.25), positive=True)
        out["nx"] = _number("domain.nx", d.get("nx", 40), positive=True, integer=True)
        out["ny"] = _number("domain.ny", d.get("ny", 8), positive=True, integer=True)
    else:
        _only("domain", d, ("shape", "path", "scale"))
        if "path" not in d:
            raise ValueError("domain.path: a 'file' domain needs the path of a mesh file (gmsh .msh, .vtk, ...)")
        out["path"] = _string("domain.path", d["path"])
        out["scale"] = _number("domain.scale", d.get("scale", 1.0), positive=True)
    return out


def _check_material(m):
    if m is None:
        raise ValueError("material: missing; a scene needs a [material] table with model, youngs_modulus, "
                         "poisson_ratio")
    m = _table("material", m)
    _only("material", m, ("model", "youngs_modulus", "poisson_ratio", "density"))
    for key in ("model", "youngs_modulus", "poisson_ratio"):
        if key not in m:
            raise ValueError(f"material.{key}: missing")
    out = {
        "model": _string("material.model", m["model"], sorted(MATERIALS)),
        "youngs_modulus": _number("material.youngs_modulus", m["youngs_modulus"], positive=True),
        "poisson_ratio": _number("material.poisson_ratio", m["poisson_ratio"], below=0.5),
        "density": _number("material.density", m.get("density", 1.0), positive=True),
    }
    if out["poisson_ratio"] <= -1:
        raise ValueError(f"material.poisson_ratio must be > -1, got {m['poisson_ratio']!r}")
    return out


def _check_region(field, r):
    if isinstance(r, str):
        return r
    r = _table(field, r)
    if "box" in r:
        _only(field, r, ("box",))
        box = r["box"]
        if not isinstance(box, (list, tuple)) or len(box) != 4:
            raise ValueError(f"{field}.box must be [xmin, ymin, xmax, ymax], got {box!r}")
        box = [_number(f"{field}.box[{i}]", b) for i, b in enumerate(box)]
        if box[0] > box[2] or box[1] > box[3]:
            raise ValueError(f"{field}.box must have xmin <= xmax and ymin <= ymax, got {box}")
        return {"box": box}
    if "near" in r:
        _only(field, r, ("near", "radius"))
        return {"near": _vector(f"{field}.near", r["near"]),
                "radius": _number(f"{field}.radius", r.get("radius", 0.05), positive=True)}
    if "nodes" in r:
        _only(field, r, ("nodes",))
        nodes = r["nodes"]
        if not isinstance(nodes, (list, tuple)) or not nodes:
            raise ValueError(f"{field}.nodes must be a non-empty list of node indices")
        return {"nodes": [_number(f"{field}.nodes[{i}]", n, nonnegative=True, integer=True)
                          for i, n in enumerate(nodes)]}
    raise ValueError(f"{field} must be a boundary name or a table with 'box', 'near' (+ 'radius') or 'nodes', "
                     f"got {r!r}")


def _check_entry(kind, i, e):
    field = f"effects.{kind}[{i}]"
    e = _table(field, e)
    if kind == "handles":
        _only(field, e, ("name", "region", "target"))
        if "region" not in e:
            raise ValueError(f"{field}.region: missing (a boundary name, a box or a point with radius)")
        return {"name": _string(f"{field}.name", e.get("name", f"handle{i}")),
                "region": _check_region(f"{field}.region", e["region"]),
                "target": _vector(f"{field}.target", e.get("target", [0.0, 0.0]))}
    if kind == "tractions":
        _only(field, e, ("boundary", "traction"))
        for key in ("boundary", "traction"):
            if key not in e:
                raise ValueError(f"{field}.{key}: missing")
        return {"boundary": _string(f"{field}.boundary", e["boundary"]),
                "traction": _vector(f"{field}.traction", e["traction"])}
    if kind == "probes":
        _only(field, e, ("center", "radius", "stiffness"))
        for key in ("center", "radius"):
            if key not in e:
                raise ValueError(f"{field}.{key}: missing")
        out = {"center": _vector(f"{field}.center", e["center"]),
               "radius": _number(f"{field}.radius", e["radius"], positive=True)}
        if "stiffness" in e:
            out["stiffness"] = _number(f"{field}.stiffness", e["stiffness"], nonnegative=True)
        return out
    if kind == "excisions":
        _only(field, e, ("polygon",))
        return {"polygon": _points(f"{field}.polygon", e.get("polygon"), 3)}
    if kind == "incisions":
        _only(field, e, ("path",))
        return {"path": _points(f"{field}.path", e.get("path"), 2)}
    # sutures
    _only(field, e, ("pairs", "stiffness", "tightness"))
    pairs = e.get("pairs")
    if not isinstance(pairs, (list, tuple)) or not pairs:
        raise ValueError(f"{field}.pairs must be a non-empty list of point pairs [[x1, y1], [x2, y2]]")
    checked = []
    for j, pair in enumerate(pairs):
        if not isinstance(pair, (list, tuple)) or len(pair) != 2:
            raise ValueError(f"{field}.pairs[{j}] must be two points [[x1, y1], [x2, y2]], got {pair!r}")
        checked.append(_points(f"{field}.pairs[{j}]", pair, 2))
    out = {"pairs": checked,
           "tightness": _number(f"{field}.tightness", e.get("tightness", 1.0), nonnegative=True)}
    if out["tightness"] > 1:
        raise ValueError(f"{field}.tightness must be in [0, 1], got {e['tightness']!r}")
    if "stiffness" in e:
        out["stiffness"] = _number(f"{field}.stiffness", e["stiffness"], positive=True)
    return out


def _check_effects(effects):
    effects = _table("effects", effects or {})
    unknown = sorted(set(effects) - set(EFFECTS))
    if unknown:
        raise ValueError(f"effects: unknown effect(s) {unknown}; known effects: {list(EFFECTS)}")
    out = {}
    if "inertia" in effects:
        e = _table("effects.inertia", effects["inertia"])
        _only("effects.inertia", e, ("time_step", "mass"))
        out["inertia"] = {"time_step": _number("effects.inertia.time_step", e.get("time_step", FRAME_BUDGET),
                                               positive=True),
                          "mass": _string("effects.inertia.mass", e.get("mass", "lumped"), ("lumped", "consistent"))}
    if "gravity" in effects:
        e = _table("effects.gravity", effects["gravity"])
        _only("effects.gravity", e, ("acceleration",))
        out["gravity"] = {"acceleration": _vector("effects.gravity.acceleration", e.get("acceleration", [0.0, -9.81]))}
    if "fibers" in effects:
        e = _table("effects.fibers", effects["fibers"])
        _only("effects.fibers", e, ("stiffness", "direction"))
        if "stiffness" not in e:
            raise ValueError("effects.fibers.stiffness: missing")
        direction = e.get("direction", [1.0, 0.0])
        if isinstance(direction, str):
            _string("effects.fibers.direction", direction, ("fusiform",))
        else:
            direction = _vector("effects.fibers.direction", direction)
            if direction == [0.0, 0.0]:
                raise ValueError("effects.fibers.direction must not be zero")
        out["fibers"] = {"stiffness": _number("effects.fibers.stiffness", e["stiffness"], nonnegative=True),
                         "direction": direction}
    if "inversion" in effects:
        e = _table("effects.inversion", effects["inversion"])
        _only("effects.inversion", e, ("method", "threshold"))
        method = _string("effects.inversion.method", e.get("method", "projected"), ("itf", "projected"))
        out["inversion"] = {"method": method}
        if method == "itf":
            out["inversion"]["threshold"] = _number("effects.inversion.threshold", e.get("threshold", 0.3),
                                                    positive=True, below=1.0)
    for kind in _LISTS:
        if kind in effects:
            entries = effects[kind]
            if isinstance(entries, dict):
                entries = [entries]
            if not isinstance(entries, (list, tuple)):
                raise ValueError(f"effects.{kind} must be a list of tables, got {entries!r}")
            if entries:  # an empty list is the same as leaving the effect out
                out[kind] = [_check_entry(kind, i, e) for i, e in enumerate(entries)]
    names = [h["name"] for h in out.get("handles", [])]
    if len(set(names)) != len(names):
        raise ValueError(f"effects.handles: names must be unique, got {names}")
    return out


def _check_solver(s):
    s = _table("solver", s or {})
    _only("solver", s, ("budget", "rtol", "linear_solver", "max_iterations"))
    return {
        "budget": _number("solver.budget", s.get("budget", FRAME_BUDGET), positive=True),
        "rtol": _number("solver.rtol", s.get("rtol", 1e-6), positive=True),
        "linear_solver": _string("solver.linear_solver", s.get("linear_solver", "reuse")),
        "max_iterations": _number("solver.max_iterations", s.get("max_iterations", 50), positive=True, integer=True),
    }


# ---------------------------------------------------------------------------------------------------------------
# TOML output (the subset scenes use: tables, arrays of tables, numbers, strings, arrays)
# ---------------------------------------------------------------------------------------------------------------

def _toml_value(v):
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, (int, np.integer)):
        return str(int(v))
    if isinstance(v, (float, np.floating)):
        return repr(float(v))  # shortest round-tripping form
    if isinstance(v, str):
        return json.dumps(v)  # a basic TOML string has JSON's escapes
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    if isinstance(v, dict):
        return "{ " + ", ".join(f"{k} = {_toml_value(x)}" for k, x in v.items()) + " }"
    raise ValueError(f"cannot write {v!r} to TOML")


def _toml(data) -> str:
    lines = []
    for key in ("name", "description"):
        if key in data:
            lines.append(f"{key} = {_toml_value(data[key])}")
    for section in ("domain", "material", "solver"):
        lines += ["", f"[{section}]"] + [f"{k} = {_toml_value(v)}" for k, v in data[section].items()]
    for kind, value in data["effects"].items():
        if kind in _LISTS:
            for entry in value:
                lines += ["", f"[[effects.{kind}]]"] + [f"{k} = {_toml_value(v)}" for k, v in entry.items()]
        else:
            lines += ["", f"[effects.{kind}]"] + [f"{k} = {_toml_value(v)}" for k, v in value.items()]
    return "\n".join(lines) + "\n"


# ---------------------------------------------------------------------------------------------------------------
# the scene
# ---------------------------------------------------------------------------------------------------------------

class Scene:
    """A checked scene description.

    ``Scene(domain=..., material=..., effects=..., solver=..., name=..., description=...)``
    with dictionaries as in a scene file; missing optional fields get their
    defaults, so :meth:`to_dict` is the complete, normalised scene.
    ``base_dir`` is where a ``file`` domain's relative path starts (the scene
    file's folder when loaded from a file).
    """

    def __init__(self, *, domain=None, material=None, effects=None, solver=None, name="scene", description="",
                 base_dir=None):
        self.name = _string("name", name)
        self.description = _string("description", description)
        self.domain = _check_domain(domain if domain is not None else {"shape": "rectangle"})
        self.material = _check_material(material)
        self.effects = _check_effects(effects)
        self.solver = _check_solver(solver)
        self.base_dir = None if base_dir is None else Path(base_dir)

    # ------------------------------------------------------------------ constructors and output
    @classmethod
    def from_dict(cls, data, base_dir=None) -> "Scene":
        data = _table("scene", data)
        _only("scene", data, ("name", "description", "domain", "material", "effects", "solver"))
        return cls(**copy.deepcopy(data), base_dir=base_dir)

    def to_dict(self) -> dict:
        out = {"name": self.name}
        if self.description:
            out["description"] = self.description
        out.update(domain=copy.deepcopy(self.domain), material=copy.deepcopy(self.material),
                   effects=copy.deepcopy(self.effects), solver=copy.deepcopy(self.solver))
        return out

    @classmethod
    def from_toml(cls, text, base_dir=None) -> "Scene":
        return cls._parse(tomllib.loads, tomllib.TOMLDecodeError, "TOML", text, base_dir)

    @classmethod
    def from_json(cls, text, base_dir=None) -> "Scene":
        return cls._parse(json.loads, json.JSONDecodeError, "JSON", text, base_dir)

    @classmethod
    def _parse(cls, loads, error, kind, text, base_dir):
        try:
            data = loads(text)
        except error as err:
            raise ValueError(f"scene: not valid {kind}: {err}") from None
        return cls.from_dict(data, base_dir)

    def to_toml(self) -> str:
        return _toml(self.to_dict())

    def to_json(self) -> str:
        return json.dumps(self.to_dict(), indent=2) + "\n"

    @classmethod
    def load(cls, path) -> "Scene":
        """Read a scene from a ``.toml`` or ``.json`` file."""
        path = Path(path)
        if path.suffix not in (".toml", ".json"):
            raise ValueError(f"scene file must end in .toml or .json, got {path.name!r}")
        text = path.read_text(encoding="utf-8")
        reader = cls.from_toml if path.suffix == ".toml" else cls.from_json
        return reader(text, base_dir=path.parent)

    def save(self, path) -> None:
        path = Path(path)
        if path.suffix not in (".toml", ".json"):
            raise ValueError(f"scene file must end in .toml or .json, got {path.name!r}")
        path.write_text(self.to_toml() if path.suffix == ".toml" else self.to_json(), encoding="utf-8")

    def __eq__(self, other):
        return isinstance(other, Scene) and self.to_dict() == other.to_dict()

    def __repr__(self):
        return f"Scene({self.name!r}: {self.domain['shape']}, {self.material['model']}, effects {list(self.effects)})"

    # ------------------------------------------------------------------ building
    @property
    def dynamic(self) -> bool:
        return "inertia" in self.effects

    def build_mesh(self):
        d = self.domain
        if d["shape"] == "rectangle":
            return meshes.mesh_with_about(d["triangles"], d["width"], d["height"])
        if d["shape"] == "flap":
            return meshes.flap(d["width"], d["height"], d["triangles"])
        if d["shape"] == "fusiform":
            return meshes.fusiform_muscle(d["length"], d["max_width"], d["tendon_width"], d["nx"], d["ny"])
        return read_mesh(Path(d["path"]) if self.base_dir is None else self.base_dir / d["path"], d["scale"])

    def build_material(self):
        m = self.material
        mat = make_material(m["model"], m["youngs_modulus"], m["poisson_ratio"])
        inv = self.effects.get("inversion")
        if inv is not None:
            from ..engine.inversion import ITFClamped, ProjectedTangent

            if inv["method"] == "itf":
                if m["model"] != "neo-hookean":
                    raise ValueError("effects.inversion.method: 'itf' clamps the ln J model only "
                                     f"(material.model = 'neo-hookean'), got {m['model']!r}; use 'projected'")
                mat = ITFClamped(mat, threshold=inv["threshold"])
            else:
                mat = ProjectedTangent(mat)
        return mat


def read_mesh(path, scale=1.0):
    """A 2D triangle mesh from a file meshio reads (gmsh ``.msh``, ``.vtk``, ``.xdmf`` ...).

    Physical line groups become named boundaries. Points must lie in the
    plane (a zero third coordinate is dropped).
    """
    path = Path(path)
    if not path.exists():
        raise ValueError(f"domain.path: no mesh file {str(path.name)!r} (looked in the scene's folder)")
    try:
        mesh = skfem.MeshTri.load(str(path))
    except Exception as err:  # meshio raises many kinds
        raise ValueError(f"domain.path: could not read {path.name!r} as a triangle mesh: {err}") from None
    if scale != 1.0:
        mesh = skfem.MeshTri(mesh.p * scale, mesh.t, _boundaries=mesh.boundaries)
    return mesh


def demo_scene(n_triangles=400, dynamic=True) -> Scene:
    """A small ready-made scene: a 2 x 1 sheet of stable neo-Hookean tissue held on its left edge."""
    effects = {"handles": [{"name": "fixed", "region": "left"}]}
    if dynamic:
        effects["inertia"] = {"time_step": FRAME_BUDGET}
    return Scene(
        name="sheet",
        domain={"shape": "rectangle", "width": 2.0, "height": 1.0, "triangles": n_triangles},
        material={"model": "stable-neo-hookean", "youngs_modulus": 1000.0, "poisson_ratio": 0.3},
        effects=effects,
    )


# ---------------------------------------------------------------------------------------------------------------
# the running simulation
# ---------------------------------------------------------------------------------------------------------------

class Simulation:
    """A scene, built and running: frames, and the surgical operations between them.

    Parameters
    ----------
    scene : Scene
    clock
        Seconds (default :func:`time.perf_counter`); tests pass a fake clock.
    linear_solver
        Overrides the scene's ``solver.linear_solver``.
    constant_tangent
        Use :class:`~tissuefem.realtime.ConstantTangentSolver` when the model is
        quadratic (default). ``False`` forces the general Newton loop (to
        measure what the shortcut saves).
    """

    def __init__(self, scene: Scene, *, clock=time.perf_counter, linear_solver=None, constant_tangent=True):
        if not isinstance(scene, Scene):
            raise ValueError(f"scene must be a Scene, got {scene!r}")
        self.scene = scene
        self.clock = clock
        self._linear_choice = linear_solver or scene.solver["linear_solver"]
        self._constant_tangent = bool(constant_tangent)
        self.density = scene.material["density"]
        self.material = scene.build_material()
        mesh = scene.build_mesh()
        fx = scene.effects.get("fibers")
        fibers = None
        if fx is not None:
            if fx["direction"] == "fusiform":
                if scene.domain["shape"] != "fusiform":
                    raise ValueError("effects.fibers.direction: 'fusiform' needs domain.shape = 'fusiform'")
                g = meshes.fusiform_fiber_field(mesh)
            else:
                g = np.repeat(np.asarray(fx["direction"], dtype=float)[:, None], mesh.nelements, axis=1)
            fibers = (fx["stiffness"], g)
        self._fibers = fibers
        self.mesh = mesh
        self._grab_count = 0
        # handles: resolved to nodes on the original mesh, then carried through the edits
        self.handles = {}
        for i, h in enumerate(scene.effects.get("handles", [])):
            nodes = self._region_nodes(mesh, h["region"], f"effects.handles[{i}].region")
            self.handles[h["name"]] = NodeHandle(nodes, h["target"], name=h["name"])
        if not self.handles and not scene.dynamic:
            raise ValueError("effects.handles: a quasistatic scene needs at least one handle (e.g. a fixed edge), "
                             "or the body floats freely")
        self._probe_specs = []
        self._probe_count = 0
        #: pieces lifted out because nothing held them (quasistatic scenes only; see _drop_loose_pieces)
        self.removed_pieces = 0
        self._sutures = None
        self._state = None
        for i, e in enumerate(scene.effects.get("excisions", [])):
            self._apply_edit(_surgery().excise, np.asarray(e["polygon"], dtype=float), f"effects.excisions[{i}]",
                             rebuild=False)
        for i, e in enumerate(scene.effects.get("incisions", [])):
            self._apply_edit(_surgery().incise, np.asarray(e["path"], dtype=float), f"effects.incisions[{i}]",
                             rebuild=False)
        self._rebuild()
        for i, p in enumerate(scene.effects.get("probes", [])):
            self.add_probe(p["center"], p["radius"], p.get("stiffness"), _field=f"effects.probes[{i}]")
        for i, s in enumerate(scene.effects.get("sutures", [])):
            self.suture(s["pairs"], stiffness=s.get("stiffness"), tightness=s["tightness"],
                        _field=f"effects.sutures[{i}]")

    # ------------------------------------------------------------------ building
    @staticmethod
    def _region_nodes(mesh, region, field):
        p = mesh.p
        if isinstance(region, str):
            if mesh.boundaries is None or region not in mesh.boundaries:
                names = sorted(mesh.boundaries) if mesh.boundaries else []
                raise ValueError(f"{field}: {region!r} is not a boundary of the mesh; boundaries: {names}")
            nodes = np.unique(mesh.facets[:, mesh.boundaries[region]])
        elif "box" in region:
            x0, y0, x1, y1 = region["box"]
            tol = 1e-9 * max(1.0, float(np.ptp(p)))
            nodes = np.flatnonzero((p[0] >= x0 - tol) & (p[0] <= x1 + tol) & (p[1] >= y0 - tol) & (p[1] <= y1 + tol))
        elif "near" in region:
            d = np.hypot(p[0] - region["near"][0], p[1] - region["near"][1])
            nodes = np.flatnonzero(d <= region["radius"] * (1 + 1e-9))  # a node exactly on the circle counts
        else:
            nodes = np.asarray(region["nodes"], dtype=np.intp)
            if nodes.max() >= mesh.nvertices:
                raise ValueError(f"{field}.nodes: indices must be below the mesh's {mesh.nvertices} nodes")
        if nodes.size == 0:
            lo, hi = p.min(axis=1), p.max(axis=1)
            raise ValueError(f"{field}: selects no node of the mesh (it lies outside the domain, which spans "
                             f"x {lo[0]:g}..{hi[0]:g}, y {lo[1]:g}..{hi[1]:g})")
        return nodes

    @property
    def dynamic(self) -> bool:
        return self.scene.dynamic

    def _external(self, basis):
        loads, names = None, []
        g = self.scene.effects.get("gravity")
        body = None
        if g is not None:
            body = self.density * np.asarray(g["acceleration"], dtype=float)
            names.append("gravity")
        tractions = [(t["boundary"], t["traction"]) for t in self.scene.effects.get("tractions", [])]
        if tractions:
            names.append("tractions")
        if body is not None or tractions:
            try:
                loads = load_vector(basis, body, tractions)
            except ValueError as err:
                raise ValueError(f"effects.tractions: {err}") from None
        return loads, names

    def _rebuild(self):
        """Build the model and the solver for the current mesh, keeping the state (if any)."""
        probes = [dict(center=p["center"], radius=p["radius"], stiffness=p["stiffness"], label=p["label"])
                  for p in self._probe_specs]
        model = Model(self.mesh, self.material, fibers=self._fibers, handles=list(self.handles.values()),
                      probes=probes, sutures=self._sutures)
        # the constant loads need the model's basis
        external, names = self._external(model.basis)
        if external is not None:
            model.external = external
        model.loads = names
        solver_options = dict(budget=self.scene.solver["budget"], rtol=self.scene.solver["rtol"], clock=self.clock,
                              max_iterations=self.scene.solver["max_iterations"])
        inertia = self.scene.effects.get("inertia")
        if inertia is not None:
            solver_options.update(dt=inertia["time_step"], density=self.density, mass=inertia["mass"])
        else:
            solver_options.update(dt=None)
        if model.quadratic and self._constant_tangent:
            choice = self._linear_choice
            if choice in ("reuse", "direct"):
                choice = "superlu"
            elif isinstance(choice, str) and choice.startswith("reuse-"):  # the factorisation is kept anyway
                choice = choice[len("reuse-"):]
            solver = ConstantTangentSolver(model, linear_solver=choice, **solver_options)
        else:
            solver = RealtimeSolver(model, linear_solver=self._linear_choice, **solver_options)
        if self._state is not None:
            u, v, v_prev, t, frames, budget, dt = self._state
            solver.u, solver.v, solver._v_previous = u, v, v_prev
            solver.time, solver.frames, solver.budget = t, frames, budget
            if dt is not None:
                solver.dt = dt
            solver.last_report = self.solver.last_report if hasattr(self, "solver") else None
        self.model, self.solver = model, solver
        self._state = None

    @contextlib.contextmanager
    def _transaction(self):
        """Apply a change completely or not at all: on any error, everything is put back as it was."""
        saved = (self.mesh, dict(self.handles), self._fibers, copy.deepcopy(self._sutures),
                 copy.deepcopy(self._probe_specs), getattr(self, "model", None),
                 getattr(self, "solver", None), self._grab_count, self._probe_count)
        try:
            yield
        except BaseException:
            (self.mesh, self.handles, self._fibers, self._sutures, self._probe_specs, model, solver,
             self._grab_count, self._probe_count) = saved
            self._state = None
            if model is not None:
                self.model, self.solver = model, solver
                model.handles = list(self.handles.values())
            raise

    def _check_held(self):
        """A quasistatic scene must keep at least one handle (or the body floats and K is singular)."""
        if not self.dynamic and not self.handles:
            raise ValueError("handles: a quasistatic scene needs at least one handle; this change would leave none")

    def _save_state(self):
        s = self.solver
        self._state = (s.u.copy(), s.v.copy(), None if s._v_previous is None else s._v_previous.copy(),
                       s.time, s.frames, s.budget, s.dt)

    # ------------------------------------------------------------------ frames
    @property
    def terms(self) -> list[str]:
        """The energy terms and loads the model evaluates, plus "inertia" for a dynamic scene and the
        inversion handling wrapped around the elastic term."""
        names = self.model.term_names
        if "inversion" in self.scene.effects:  # the elastic term's material is wrapped, not a term of its own
            names = names[:1] + [f"inversion ({self.scene.effects['inversion']['method']})"] + names[1:]
        return (["inertia"] if self.dynamic else []) + names

    @property
    def u(self):
        return self.solver.u

    @property
    def v(self):
        return self.solver.v

    @property
    def frames(self) -> int:
        return self.solver.frames

    @property
    def time(self) -> float:
        return self.solver.time

    def frame(self, targets=None):
        """One frame. ``targets``: ``{handle name: translation (dx, dy) or map}`` (others keep theirs)."""
        index = None
        if targets:
            if not isinstance(targets, dict):
                raise ValueError(f"targets must be a dict {{handle name: target}}, got {targets!r}")
            names = list(self.handles)
            index = {}
            for name, t in targets.items():
                if name not in self.handles:
                    raise ValueError(f"targets: no handle named {name!r}; handles: {names}")
                index[names.index(name)] = t
        return self.solver.frame(index)

    def run(self, frames: int, targets=None):
        """Run ``frames`` frames (with the same ``targets`` for each); return the reports."""
        return [self.frame(targets) for _ in range(int(frames))]

    def positions(self) -> np.ndarray:
        """Deformed node positions ``x = X + u`` ``(2, n_nodes)``."""
        return self.model.positions(self.solver.u)

    def total_mass(self) -> float:
        return self.model.mass(self.density)

    def momentum(self) -> np.ndarray:
        if self.solver.M is None:
            return np.zeros(2)
        p = self.solver.M @ self.solver.v
        return np.array([p[0::2].sum(), p[1::2].sum()])

    def pieces(self) -> int:
        """How many separate pieces the tissue is in."""
        return _surgery().connected_components(self.mesh.t, self.mesh.nvertices)[0]

    def tension(self) -> np.ndarray:
        """Largest principal Cauchy stress per element (see :meth:`tissuefem.model.Model.tension`)."""
        return self.model.tension(self.solver.u)

    # ------------------------------------------------------------------ handles: pull and drag
    def _mean_edge(self):
        p, f = self.mesh.p, self.mesh.facets
        return float(np.mean(np.hypot(*(p[:, f[0]] - p[:, f[1]]))))

    def grab(self, point, radius=None) -> str:
        """Grab the nodes within ``radius`` of ``point`` (deformed coordinates); returns the handle's name.

        The grabbed nodes stay where they are until :meth:`drag` moves them (by
        the mouse's offset from the grab point). Default radius: 1.5 mean edge lengths.
        """
        radius = 1.5 * self._mean_edge() if radius is None else _number("radius", radius, positive=True)
        point = _vector2("point", point)
        x = self.positions()
        d = np.hypot(x[0] - point[0], x[1] - point[1])
        nodes = np.flatnonzero(d <= radius)
        if nodes.size == 0:
            raise ValueError(f"point {point.tolist()}: no tissue within radius {radius:g}")
        self._grab_count += 1
        name = f"grab{self._grab_count}"
        while name in self.handles:  # never replace a scene's handle of the same name
            self._grab_count += 1
            name = f"grab{self._grab_count}"
        u = self.solver.u.reshape(-1, 2).T
        handle = NodeHandle(nodes, base=u[:, nodes].copy(), name=name)
        handle.anchor = point
        self.handles[name] = handle
        self.model.handles = list(self.handles.values())
        return name

    def drag(self, name, point) -> None:
        """Move a grabbed handle so that its grab point follows ``point``."""
        h = self._handle(name)
        point = _vector2("point", point)
        anchor = getattr(h, "anchor", None)
        self._set_target(h, point - (np.zeros(2) if anchor is None else anchor))

    def handle_offset(self, name) -> np.ndarray:
        t = self._handle(name).target
        return None if callable(t) else t.copy()

    def move_handle(self, name, target) -> None:
        """Set a handle's target (a translation or a map), checked; takes effect at the next frame."""
        self._set_target(self._handle(name), target)

    def _set_target(self, handle, target):
        old = handle.target
        handle.move(target)
        try:  # a map is evaluated once now, so a bad one is refused here and not at every later frame
            handle.displacement(self.model.X[:, handle.nodes])
        except ValueError:
            handle.target = old
            raise

    def release(self, name) -> None:
        """Let go of a handle: its nodes are free from the next frame on."""
        handle = self._handle(name)
        del self.handles[name]
        try:
            self._check_held()
        except ValueError:
            self.handles[name] = handle
            raise
        self.model.handles = list(self.handles.values())

    def _handle(self, name):
        if name not in self.handles:
            raise ValueError(f"no handle named {name!r}; handles: {list(self.handles)}")
        return self.handles[name]

    # ------------------------------------------------------------------ probe
    def add_probe(self, center, radius, stiffness=None, _field="probe"):
        """Press a rigid disc (a tool tip) into the tissue; returns its label for :meth:`move_probe`."""
        center = _vector2(f"{_field}.center", center).tolist()
        radius = _number(f"{_field}.radius", radius, positive=True)
        E = self.scene.material["youngs_modulus"]
        if stiffness is None:  # stiff enough to keep penetration to a few percent of the radius
            with np.errstate(over="ignore"):
                stiffness = _number(f"{_field}.stiffness (default 1e3 E / radius^2)", 1e3 * E / radius**2)
        else:
            stiffness = _number(f"{_field}.stiffness", stiffness, nonnegative=True)
        with self._transaction():
            self._probe_count += 1
            label = f"probe{self._probe_count}"
            self._probe_specs.append(dict(center=center, radius=radius, stiffness=stiffness, label=label))
            self._save_state()
            self._rebuild()
        return label

    def _probe(self, label):
        for p in self.model.probes:
            if p.label == label:
                return p
        raise ValueError(f"no probe named {label!r}; probes: {[p.label for p in self.model.probes]}")

    def move_probe(self, label, center) -> None:
        probe = self._probe(label)
        probe.move(center)
        for spec in self._probe_specs:
            if spec["label"] == label:
                spec["center"] = list(probe.center)

    def remove_probe(self, label) -> None:
        self._probe(label)
        with self._transaction():
            self._probe_specs = [p for p in self._probe_specs if p["label"] != label]
            self._save_state()
            self._rebuild()

    # ------------------------------------------------------------------ topology changes
    def _apply_edit(self, operation, argument, field, rebuild=True):
        running = hasattr(self, "solver")
        try:
            if operation is _surgery().incise:  # cut where the user drew, on the deformed tissue
                edit = operation(self.mesh, argument, self.positions() if running else None)
            else:
                edit = operation(self.mesh, argument)
        except ValueError as err:
            raise ValueError(f"{field}: {err}") from None
        with self._transaction():
            if running:
                self._save_state()
            if not self.dynamic:
                edit = self._drop_loose_pieces(edit)
            parent = edit.parent
            # carry everything node- and element-based over
            new_handles = {}
            for name, h in self.handles.items():
                moved = h.remap(parent)
                if moved is not None:
                    anchor = getattr(h, "anchor", None)
                    if anchor is not None:
                        moved.anchor = anchor
                    new_handles[name] = moved
            self.handles = new_handles
            self._check_held()
            if self._fibers is not None:
                self._fibers = (self._fibers[0], self._fibers[1][:, edit.elements])
            if self._sutures is not None:
                self._sutures = self._remap_sutures(self._sutures, parent)
            if self._state is not None:
                u, v, v_prev, t, frames, budget, dt = self._state

                def carry(w):
                    return None if w is None else w.reshape(-1, 2)[parent].ravel()

                self._state = (carry(u), carry(v), carry(v_prev), t, frames, budget, dt)
            self.mesh = edit.mesh
            if rebuild:
                self._rebuild()
        return edit

    def _drop_loose_pieces(self, edit):
        """Quasistatic scenes: remove pieces that nothing holds (no handle, no suture to a held piece).

        Such a piece has no equilibrium (its stiffness matrix is singular, and
        under a load it would run away), so it is lifted out of the simulation,
        as a surgeon lifts out what was cut free. Dynamic scenes keep every piece.
        """
        import scipy.sparse as sp
        from scipy.sparse.csgraph import connected_components

        mesh = edit.mesh
        n = mesh.nvertices
        t = mesh.t
        rows = [t[0], t[1], t[2]]
        cols = [t[1], t[2], t[0]]
        if self._sutures is not None:
            sutures = self._remap_sutures(self._sutures, edit.parent)
            if sutures is not None:
                rows.append(sutures["pairs"][0])
                cols.append(sutures["pairs"][1])
        r, c = np.concatenate(rows), np.concatenate(cols)
        graph = sp.coo_matrix((np.ones(r.size), (r, c)), shape=(n, n))
        _, labels = connected_components(graph, directed=False)
        held = np.zeros(labels.max() + 1, dtype=bool)
        for h in self.handles.values():
            moved = h.remap(edit.parent)
            if moved is not None:
                held[labels[moved.nodes]] = True
        loose = ~held[labels[t[0]]]
        if not np.any(loose) or np.all(loose):
            return edit  # nothing to drop (or nothing held at all: _check_held reports it)
        second = _surgery().excise(mesh, lambda centroids: loose)
        self.removed_pieces += 1
        return dataclasses.replace(second, parent=edit.parent[second.parent], elements=edit.elements[second.elements],
                                   cut_edges=edit.cut_edges, n_old_nodes=edit.n_old_nodes,
                                   n_old_elements=edit.n_old_elements)

    @staticmethod
    def _remap_sutures(sutures, parent):
        # a sutured node keeps its number if it survives (cuts keep old numbers); else its first copy
        first = np.full(int(max(parent.max(initial=0), np.max(sutures["pairs"]))) + 1, -1, dtype=np.intp)
        first[parent[::-1]] = np.arange(parent.size)[::-1]
        pairs = np.asarray(sutures["pairs"])
        a, b = first[pairs[0]], first[pairs[1]]
        keep = (a >= 0) & (b >= 0)
        if not np.any(keep):
            return None
        k = pairs.shape[1]
        return {
            "pairs": np.vstack([a[keep], b[keep]]),
            "gaps": np.asarray(sutures["gaps"])[:, keep],
            "stiffness": np.broadcast_to(np.asarray(sutures["stiffness"], float), (k,))[keep],
            "tightness": np.broadcast_to(np.asarray(sutures.get("tightness", 0.0), float), (k,))[keep],
        }

    def cut(self, polyline):
        """Incise along ``polyline`` (points in deformed coordinates), duplicating nodes along the cut.

        The state carries over: each copy of a node gets its displacement and
        velocity. Returns the :class:`tissuefem.surgery.MeshEdit`.
        """
        return self._apply_edit(_surgery().incise, _polyline(polyline), "polyline")

    def excise(self, region):
        """Remove the elements inside ``region`` (a polygon in *reference* coordinates, or a mask on centroids)."""
        if not callable(region):
            region = _polyline(region, minimum=3, field="region")
        return self._apply_edit(_surgery().excise, region, "region")

    # ------------------------------------------------------------------ sutures
    def _snap(self, point, field):
        """The node nearest to ``point`` (deformed coordinates); among coincident copies of a cut node, the
        one on the side of the point (whose elements' centroids are nearest)."""
        x = self.positions()
        d = np.hypot(x[0] - point[0], x[1] - point[1])
        best = np.flatnonzero(d <= d.min() + 1e-12 * max(1.0, float(np.ptp(x))))
        if best.size == 1:
            return int(best[0])
        t = self.mesh.t
        centroids = x[:, t].mean(axis=1)
        scores = []
        for node in best:
            elems = np.flatnonzero(np.any(t == node, axis=0))
            c = centroids[:, elems].mean(axis=1)
            scores.append(np.hypot(*(c - point)))
        return int(best[int(np.argmin(scores))])

    def suture(self, pairs, stiffness=None, tightness=1.0, _field="sutures"):
        """Tie pairs of points together with stiff springs.

        ``pairs``: point pairs ``[[[x1, y1], [x2, y2]], ...]`` in deformed
        coordinates (snapped to the nearest nodes), or node index pairs as an
        integer array ``(2, k)``. The springs start slack (no force) and are
        tightened to ``tightness`` (1: the points are pulled together). Default
        stiffness: 100 x Young's modulus (per unit thickness).
        """
        E = self.scene.material["youngs_modulus"]
        k = 100.0 * E if stiffness is None else _number(f"{_field}.stiffness", stiffness, positive=True)
        arr = np.asarray(pairs)
        if np.issubdtype(arr.dtype, np.integer) and arr.ndim == 2 and arr.shape[0] == 2:
            nodes = arr.astype(np.intp)
            if nodes.size == 0 or nodes.min() < 0 or nodes.max() >= self.mesh.nvertices:
                raise ValueError(f"{_field}.pairs: node indices must be in 0..{self.mesh.nvertices - 1}")
        else:
            arr = np.asarray(arr, dtype=float)
            if arr.ndim != 3 or arr.shape[1:] != (2, 2) or arr.shape[0] == 0 or not np.all(np.isfinite(arr)):
                raise ValueError(f"{_field}.pairs must be point pairs shaped (k, 2, 2), got shape {arr.shape}")
            nodes = np.array([[self._snap(p[0], _field), self._snap(p[1], _field)] for p in arr]).T
        same = nodes[0] == nodes[1]
        if np.all(same):
            raise ValueError(f"{_field}.pairs: every pair snaps to a single node; nothing to tie")
        nodes = nodes[:, ~same]
        tightness = _number(f"{_field}.tightness", tightness, nonnegative=True)
        if tightness > 1:
            raise ValueError(f"{_field}.tightness must be in [0, 1], got {tightness!r}")
        x = self.positions()
        gaps = x[:, nodes[0]] - x[:, nodes[1]]
        k_new = nodes.shape[1]
        new = {"pairs": nodes, "stiffness": np.full(k_new, k), "gaps": gaps, "tightness": np.zeros(k_new)}
        if self._sutures is not None:  # the old stitches keep their gap when placed and their tightness
            old = self._sutures
            new = {key: np.concatenate([np.asarray(old[key]), new[key]], axis=-1) for key in new}
        with self._transaction():
            self._sutures = new
            self._save_state()
            self._rebuild()
            if tightness > 0:
                self.tighten(tightness, stitches=np.arange(new["pairs"].shape[1] - k_new, new["pairs"].shape[1]))
        return nodes

    def tighten(self, fraction, stitches=None) -> None:
        """Tighten sutures: each keeps ``(1 - fraction)`` of its gap when placed as slack (1: closed).

        ``stitches``: indices of the stitches to tighten (default: all).
        """
        if self.model.sutures is None:
            raise ValueError("tighten: there are no sutures")
        self.model.sutures.tighten(fraction, stitches)
        self._sutures["tightness"] = self.model.sutures.tightness.copy()

    def suture_gaps(self) -> np.ndarray:
        """Distances between the sutured points (0 when closed)."""
        if self.model.sutures is None:
            return np.zeros(0)
        return self.model.sutures.distances(self.solver.u)


def _polyline(points, minimum=2, field="polyline"):
    try:
        arr = np.asarray(points, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"{field} must be a list of points [x, y], got {points!r}") from None
    if arr.ndim != 2 or arr.shape[1] != 2 or arr.shape[0] < minimum:
        raise ValueError(f"{field} must be at least {minimum} points shaped (k, 2), got shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{field} contains non-finite coordinates")
    return arr


def _surgery():
    from . import topology as surgery

    return surgery
