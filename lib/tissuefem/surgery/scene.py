"""Scenes: a declarative description of a simulation (run one with :class:`~tissuefem.surgery.simulation.Simulation`).

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

A :class:`~tissuefem.surgery.simulation.Simulation` builds and runs it.
"""

from __future__ import annotations

import copy
import json
import math
import tomllib
from pathlib import Path

import numpy as np
import skfem

from ..engine import meshes
from ..engine.materials import MATERIALS
from ..engine.materials import material as make_material
from ..engine.inversion import ITFClamped, ProjectedTangent
from ..engine.constants import FRAME_BUDGET, TISSUE_DENSITY, TISSUE_E, TISSUE_NU
from ..engine.linsolve import LinearSolver

__all__ = ["Scene", "EFFECTS", "SHAPES", "EXAMPLE_TOML", "demo_scene", "flap_scene", "flap_path"]

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


def _linear_solver(value):
    name = _string("solver.linear_solver", value)
    try:
        LinearSolver(name)
    except ValueError as err:
        raise ValueError(f"solver.linear_solver: {err}") from None
    return name


def _check_solver(s):
    s = _table("solver", s or {})
    _only("solver", s, ("budget", "rtol", "linear_solver", "max_iterations"))
    return {
        "budget": _number("solver.budget", s.get("budget", FRAME_BUDGET), positive=True),
        "rtol": _number("solver.rtol", s.get("rtol", 1e-6), positive=True),
        "linear_solver": _linear_solver(s.get("linear_solver", "reuse")),
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
        material={"model": "stable-neo-hookean", "youngs_modulus": TISSUE_E, "poisson_ratio": TISSUE_NU},
        effects=effects,
    )


def flap_path(t) -> np.ndarray:
    """The standard flap's scripted drag: the right edge's displacement at time ``t`` (a slow loop, period 4-8 s)."""
    t = float(t)
    return np.array([0.3 * math.sin(math.pi * t / 2.0), 0.4 * math.sin(math.pi * t / 4.0)])


def flap_scene(n_triangles: int = 8000, model: str = "neo-hookean", dynamic: bool = True, rtol: float = 1e-6,
               linear_solver: str = "reuse") -> Scene:
    """The standard scene of the benchmarks and chapters 7-9: a tissue flap pulled by its right edge.

    The flap ``[0, 2] x [0, 1]`` (E = 1000, nu = 0.3, rho0 = 1, plane strain) of
    about ``n_triangles``, its left edge ``fixed``, its right edge a ``handle``
    that :func:`flap_path` carries along a slow loop; backward Euler with
    ``dt = 1/30`` (``dynamic=False``: quasistatic frames); every frame solved to
    ``rtol`` with no wall-clock budget (a benchmark measures the frame, the
    real-time loop sets a budget).
    """
    effects = {"handles": [{"name": "fixed", "region": "fixed"}, {"name": "handle", "region": "handle"}]}
    if dynamic:
        effects["inertia"] = {"time_step": FRAME_BUDGET}
    return Scene(
        name="standard flap",
        domain={"shape": "flap", "width": 2.0, "height": 1.0, "triangles": int(n_triangles)},
        material={"model": model, "youngs_modulus": TISSUE_E, "poisson_ratio": TISSUE_NU,
                  "density": TISSUE_DENSITY},
        effects=effects,
        solver={"budget": 1e9, "rtol": rtol, "linear_solver": linear_solver},
    )
