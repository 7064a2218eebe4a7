"""Scenes: a declarative description of a simulation (run one with :class:`~tissuefem.surgery.simulation.Simulation`).

A scene names a domain, a material and the *effects* it calls for (a nested dictionary, see
:data:`EXAMPLE_TOML`, or a TOML/JSON file). The registry (:mod:`tissuefem.engine.effects`) checks and builds
the effects that become terms; the scene's own are ``inversion``, ``handles``, ``excisions`` and ``incisions``.
docs/scenes.md lists every field and its range; an invalid scene raises a ``ParameterError`` naming the field
(``effects.handles[1].region``). A ``file`` domain's size-dependent limits are checked when its mesh is read.

A scene is 2D (triangles) or 3D (tetrahedra: the ``block`` domain, or a file of tetrahedra): one set of fields
for both, whose points and vectors have the domain's dimension (``[x, y]`` or ``[x, y, z]``). The effects still
2D only (:data:`TWO_D_ONLY`: cuts and self-contact) are refused by name in a 3D scene.
"""

from __future__ import annotations

import collections
import contextlib
import copy
import io
import json
import logging
import math
import os
import re
import types
from pathlib import Path

import numpy as np
import skfem

from ..engine import meshes
from ..engine.constants import FRAME_BUDGET, TISSUE_DENSITY, TISSUE_E, TISSUE_NU
from ..engine.effects import EFFECTS as EFFECTS_REGISTRY, GRAVITY_DOWN
from ..engine.inversion import ITFClamped, ProjectedTangent
from ..engine.linsolve import LinearSolver
from ..engine.materials import MATERIALS, material as make_material
from ..engine.parameters import (DENSITY_RANGE, FAR, RADIUS_RANGE, REACH, YOUNGS_MODULUS_RANGE,
                                 ParameterError, check_poisson_ratio, check_radius, check_reach, count_list,
                                 is_sequence, number, points, require, show, string, table, vector)

__all__ = ["Scene", "EFFECTS", "SHAPES", "TWO_D_ONLY", "EXAMPLE_TOML", "demo_scene", "flap_scene", "flap_path",
           "read_mesh"]

#: How a cut or an excision meets the mesh: through the elements (:mod:`~tissuefem.surgery.element_cuts`), or
#: snapped to the mesh's edges (:mod:`~tissuefem.surgery.topology`: jagged, mesh-dependent; kept to compare)
CUT_METHODS = ("elements", "edges")
#: the effects a scene may name, the registry's and the scene's own (inversion, handles, excisions,
#: incisions), in the order in which they are checked and written
EFFECTS = ("inertia", "gravity", "fibers", "inversion", "contact", "handles", "tractions", "probes",
           "excisions", "incisions", "sutures")
#: each domain's fields and their defaults ("block": a box of tetrahedra, :func:`~tissuefem.engine.meshes.box`;
#: "file": a mesh of triangles or tetrahedra read through meshio)
_DOMAINS = {"rectangle": {"width": 1.0, "height": 1.0, "triangles": 800},
            "flap": {"width": 2.0, "height": 1.0, "triangles": 800},
            "fusiform": {"length": 4.0, "max_width": 1.0, "tendon_width": 0.25, "nx": 40, "ny": 8},
            "block": {"lx": 1.0, "ly": 1.0, "lz": 1.0, "nx": 4, "ny": 4, "nz": 4},
            "file": {"path": None, "scale": 1.0}}
SHAPES = tuple(_DOMAINS)
#: the generator of each domain's mesh (a file's is read: :func:`read_mesh`)
_MESHERS = {"rectangle": meshes.mesh_with_about, "flap": meshes.flap, "fusiform": meshes.fusiform_muscle,
            "block": meshes.box}
#: the effects a 3D scene cannot name yet (the engine's are 2D only), and what they are called in the refusal
TWO_D_ONLY = {"excisions": "cuts (excisions)", "incisions": "cuts (incisions)", "contact": "self-contact"}
#: the list-valued effects of the scene's own (each entry is a table); the registry's say whether they are
_LISTS = ("handles", "excisions", "incisions")

# --- limits (the table in docs/scenes.md): triangles, lengths (and ``domain.scale``), aspect ratio either way round
MAX_TRIANGLES, SIZE_RANGE, MAX_ASPECT = meshes.MAX_TRIANGLES, meshes.SIZE_RANGE, meshes.MAX_ASPECT
#: the integer fields of the domains and their largest values; the ratios whose aspect is limited
_COUNTS = {"triangles": MAX_TRIANGLES, "nx": MAX_TRIANGLES // 2, "ny": MAX_TRIANGLES // 2, "nz": MAX_TRIANGLES // 6}
_ASPECTS = {"rectangle": [("width", "height")], "flap": [("width", "height")],
            "fusiform": [("length", "max_width"), ("max_width", "tendon_width")],
            "block": [("lx", "ly"), ("ly", "lz"), ("lx", "lz")]}
#: elements per cell of the grid domains (a block's cell is six tetrahedra)
_PER_CELL = {"fusiform": 2, "block": 6}
THRESHOLD_RANGE = (0.01, 0.99)
BUDGET_RANGE = (1e-6, 1e9)
RTOL_RANGE = (1e-14, 0.5)
MAX_ITERATIONS = 1000
#: entries of one list-valued effect (handles, and an effect registered later); each limit is one that a test builds
#: at its maximum within a stated time (docs/scenes.md): what is accepted can also be computed
MAX_ENTRIES = 1000
#: the lower limits of the effects whose every entry rebuilds the model: an incision or an excision re-meshes and
#: rebuilds it (a cost in proportion to the mesh), a probe or a suture adds a term to it, a traction assembles a load
ENTRY_LIMITS = {"incisions": 100, "excisions": 100, "probes": 100, "sutures": 100, "tractions": 100}
#: points of an incision's path or an excision's polygon (a suture's pairs: ``MAX_POINTS``)
MAX_STROKE_POINTS = 1000
#: node indices lie below this (a mesh of MAX_TRIANGLES triangles has fewer nodes)
MAX_NODES = 3 * MAX_TRIANGLES
#: nesting of a scene's tables and arrays (a valid scene needs 7)
MAX_NESTING = 16
MAX_SCENE_BYTES = 16 * 2**20
MAX_MESH_FILE_BYTES = 64 * 2**20
# points and lengths before the domain's size is known (a file domain, FAR): beyond REACH times the largest domain
assert FAR >= (2 * REACH + 1) * meshes.COORDINATE_MAX

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


# --- checking fields ---------------------------------------------------------------------------------------------

def _within(field, value, bounds):
    return number(field, value, lo=bounds[0], hi=bounds[1])


def _check_domain(d):
    d = table("domain", d)
    shape = string("domain.shape", d.get("shape", "rectangle"), SHAPES)
    table("domain", d, ("shape", *_DOMAINS[shape]))
    if shape == "file" and "path" not in d:
        raise ParameterError("domain.path",
                             "domain.path: a 'file' domain needs the path of a mesh file (gmsh .msh, .vtk, ...)")
    out = {"shape": shape}
    for key, default in _DOMAINS[shape].items():
        field, value = f"domain.{key}", d.get(key, default)
        if key in _COUNTS:
            out[key] = number(field, value, integer=True, lo=1, hi=_COUNTS[key])
        elif key != "path":
            out[key] = _within(field, value, SIZE_RANGE)
        elif "\0" in string(field, value, nonempty=True):
            raise ParameterError("domain.path", "domain.path must not contain a NUL character")
        else:
            out[key] = value
    if shape == "fusiform" and out["tendon_width"] > out["max_width"]:
        raise ParameterError("domain.tendon_width",
                             f"domain.tendon_width must not exceed domain.max_width (the belly is widest in the "
                             f"middle), got {out['tendon_width']!r} > {out['max_width']!r}")
    for a, b in _ASPECTS.get(shape, ()):
        if not 1.0 / MAX_ASPECT <= out[a] / out[b] <= MAX_ASPECT:
            raise ParameterError(f"domain.{a}",
                                 f"domain.{a} / domain.{b} = {out[a] / out[b]:g}: the aspect ratio must lie "
                                 f"within [1/{MAX_ASPECT:g}, {MAX_ASPECT:g}]")
    if shape in _PER_CELL:
        axes = [k for k in ("nx", "ny", "nz") if k in out]
        elements = _PER_CELL[shape] * math.prod(out[k] for k in axes)
        if elements > MAX_TRIANGLES:
            noun = "tetrahedra" if shape == "block" else "triangles"
            raise ParameterError("domain.nx",
                                 f"{', '.join(f'domain.{k}' for k in axes)}: {' x '.join(str(out[k]) for k in axes)} "
                                 f"cells make {elements} {noun}, more than {MAX_TRIANGLES}")
    return out


def _domain_box(domain):
    """The bounding box ``(lower corner, upper corner)`` of a generated domain (``None`` for a file)."""
    if domain["shape"] in ("rectangle", "flap"):
        return [0.0, 0.0], [domain["width"], domain["height"]]
    if domain["shape"] == "fusiform":
        return [0.0, -0.5 * domain["max_width"]], [domain["length"], 0.5 * domain["max_width"]]
    if domain["shape"] == "block":
        return [0.0, 0.0, 0.0], [domain["lx"], domain["ly"], domain["lz"]]
    return None


def _check_material(m):
    if m is None:
        raise ParameterError("material",
                             "material: missing; a scene needs a [material] table with model, youngs_modulus, "
                             "poisson_ratio")
    m = table("material", m, ("model", "youngs_modulus", "poisson_ratio", "density"))
    require("material", m, ("model", "youngs_modulus", "poisson_ratio"))
    return {
        "model": string("material.model", m["model"], sorted(MATERIALS)),
        "youngs_modulus": _within("material.youngs_modulus", m["youngs_modulus"], YOUNGS_MODULUS_RANGE),
        "poisson_ratio": check_poisson_ratio(number("material.poisson_ratio", m["poisson_ratio"]),
                                             "material.poisson_ratio"),
        "density": _within("material.density", m.get("density", 1.0), DENSITY_RANGE),
    }


def _check_region(field, r):
    if isinstance(r, str):
        return string(field, r, nonempty=True)
    r = table(field, r)
    if "box" in r:
        box = table(field, r, ("box",))["box"]
        if not is_sequence(box) or len(box) not in (4, 6):
            raise ParameterError(f"{field}.box", f"{field}.box must be [xmin, ymin, xmax, ymax] (3D: [xmin, ymin, "
                                                 f"zmin, xmax, ymax, zmax]), got {show(box)}")
        box = [number(f"{field}.box[{i}]", b, lo=-FAR, hi=FAR) for i, b in enumerate(box)]
        d = len(box) // 2
        if any(box[i] > box[d + i] for i in range(d)):
            order = " and ".join(f"{c}min <= {c}max" for c in "xyz"[:d])
            raise ParameterError(f"{field}.box", f"{field}.box must have {order}, got {box}")
        return {"box": box}
    if "near" in r:
        table(field, r, ("near", "radius"))
        return {"near": vector(f"{field}.near", r["near"]),
                "radius": _within(f"{field}.radius", r.get("radius", 0.05), (RADIUS_RANGE[0] * SIZE_RANGE[0], FAR))}
    if "nodes" in r:
        nodes = count_list(f"{field}.nodes", table(field, r, ("nodes",))["nodes"], "node indices", MAX_NODES)
        return {"nodes": [number(f"{field}.nodes[{i}]", n, integer=True, lo=0, hi=MAX_NODES - 1)
                          for i, n in enumerate(nodes)]}
    raise ParameterError(field,
                         f"{field} must be a boundary name or a table with 'box', 'near' (+ 'radius') or 'nodes', "
                         f"got {show(r)}")


def _listed(kind) -> bool:
    return kind in _LISTS or (kind in EFFECTS_REGISTRY and EFFECTS_REGISTRY[kind].listed)


def _check_entry(kind, i, e, dim):
    field = f"effects.{kind}[{i}]"
    if kind in EFFECTS_REGISTRY:
        return EFFECTS_REGISTRY[kind].check(field, e)
    if kind == "handles":
        e = table(field, e, ("name", "region", "target"))
        if "region" not in e:
            raise ParameterError(f"{field}.region", f"{field}.region: missing (a boundary name, a box or a "
                                                    "point with radius)")
        out = {"name": string(f"{field}.name", e.get("name", f"handle{i}")),
               "region": _check_region(f"{field}.region", e["region"])}
        if "target" in e or dim is not None:  # a file's handle without a target: held, in the mesh's dimension
            out["target"] = vector(f"{field}.target", e.get("target", [0.0] * (dim or 2)))
        return out
    key, least = ("polygon", 3) if kind == "excisions" else ("path", 2)
    e = table(field, e, (key, "method"))
    return {key: points(f"{field}.{key}", e.get(key), least, MAX_STROKE_POINTS),
            "method": string(f"{field}.method", e.get("method", "elements"), CUT_METHODS)}


def _check_inversion(e):
    e = table("effects.inversion", e, ("method", "threshold"))
    method = string("effects.inversion.method", e.get("method", "projected"), ("itf", "projected"))
    if method == "itf":
        return {"method": method, "threshold": _within("effects.inversion.threshold", e.get("threshold", 0.3),
                                                       THRESHOLD_RANGE)}
    if "threshold" in e:
        raise ParameterError("effects.inversion.threshold",
                             "effects.inversion.threshold: only the 'itf' method has a threshold")
    return {"method": method}


def _check_effects(effects, dim=2):
    """The checked effects of a scene of dimension ``dim`` (``None``: a file's, known once read): defaults that are
    vectors take that dimension (a file's are left out and taken in the mesh's when it is read)."""
    effects = table("effects", effects)
    # the scene's own and the registry's (the engine's and any registered since)
    known = list(EFFECTS) + [k for k, e in EFFECTS_REGISTRY.items() if e.check is not None and k not in EFFECTS]
    unknown = [k for k in effects if k not in known]
    if unknown:
        raise ParameterError("effects", f"effects: unknown effect(s) [{', '.join(sorted(show(k) for k in unknown))}]; "
                                        f"known effects: {known}")
    out = {}
    for kind in [k for k in known if k in effects]:
        field, entries = f"effects.{kind}", effects[kind]
        if kind == "inversion":
            out[kind] = _check_inversion(entries)
        elif not _listed(kind):
            out[kind] = EFFECTS_REGISTRY[kind].check(field, entries)
            if kind == "gravity" and isinstance(entries, dict) and "acceleration" not in entries:
                if dim is None:  # taken in the mesh's dimension when it is read
                    del out[kind]["acceleration"]
                else:
                    out[kind]["acceleration"] = list(GRAVITY_DOWN[:dim])
        elif not (is_sequence(entries) and len(entries) == 0):  # an empty list is the same as leaving it out
            entries = count_list(field, [entries] if isinstance(entries, dict) else entries, "entries",
                                 ENTRY_LIMITS.get(kind, MAX_ENTRIES))
            out[kind] = [_check_entry(kind, i, e, dim) for i, e in enumerate(entries)]
    names = [h["name"] for h in out.get("handles", [])]
    if len(set(names)) != len(names):
        raise ParameterError("effects.handles", f"effects.handles: names must be unique, got {show(names)}")
    return out


def _check_solver(s):
    s = table("solver", s, ("budget", "rtol", "linear_solver", "max_iterations"))
    out = {"budget": _within("solver.budget", s.get("budget", FRAME_BUDGET), BUDGET_RANGE),
           "rtol": _within("solver.rtol", s.get("rtol", 1e-6), RTOL_RANGE),
           "linear_solver": string("solver.linear_solver", s.get("linear_solver", "reuse"))}
    try:
        LinearSolver(out["linear_solver"])
    except ValueError as err:
        raise ParameterError("solver.linear_solver", f"solver.linear_solver: {err}") from None
    out["max_iterations"] = number("solver.max_iterations", s.get("max_iterations", 50), integer=True, lo=1,
                                   hi=MAX_ITERATIONS)
    return out


def _check_2d_only(effects, dim, where=""):
    """Refuse, naming the effect, what a 3D scene cannot have yet (:data:`TWO_D_ONLY`)."""
    for kind, what in TWO_D_ONLY.items():
        if dim == 3 and kind in effects:
            raise ParameterError(f"effects.{kind}", f"effects.{kind}: {what} are 2D only for now, and this scene "
                                                    f"is 3D (tetrahedra{where}); leave effects.{kind} out")


def _placed(effects):
    """``(field, kind, value)`` of each ``"point"`` (a handle's ``"box"``: its two corners), ``"radius"``,
    ``"displacement"`` (a handle's target) and other ``"vector"`` of checked effects, in the order they are checked."""
    for i, h in enumerate(effects.get("handles", [])):
        region = h["region"] if isinstance(h["region"], dict) else {}
        for key, kind in (("box", "box"), ("near", "point"), ("radius", "radius")):
            if key in region:
                yield f"effects.handles[{i}].region.{key}", kind, region[key]
        if "target" in h:
            yield f"effects.handles[{i}].target", "displacement", h["target"]
    for kind, key in (("gravity", "acceleration"), ("fibers", "direction")):
        if isinstance(effects.get(kind, {}).get(key), list):  # a file's default gravity, fibres "fusiform": none
            yield f"effects.{kind}.{key}", "vector", effects[kind][key]
    for i, t in enumerate(effects.get("tractions", [])):
        yield f"effects.tractions[{i}].traction", "vector", t["traction"]
    for i, p in enumerate(effects.get("probes", [])):
        yield f"effects.probes[{i}].center", "point", p["center"]
        yield f"effects.probes[{i}].radius", "radius", p["radius"]
    for kind, key in (("excisions", "polygon"), ("incisions", "path")):
        for i, e in enumerate(effects.get(kind, [])):
            yield from ((f"effects.{kind}[{i}].{key}[{j}]", "point", q) for j, q in enumerate(e[key]))
    for i, e in enumerate(effects.get("sutures", [])):
        for j, pair in enumerate(e["pairs"]):
            yield from ((f"effects.sutures[{i}].pairs[{j}][{k}]", "point", q) for k, q in enumerate(pair))


def _check_reach(effects, lo, hi, where=""):
    """Points and vectors against the domain, the box ``lo``-``hi`` of size ``L`` (its longest side): each has the
    domain's dimension; points and displacements lie within ``REACH L`` of its centre, radii within
    ``RADIUS_RANGE L``."""
    lo, hi = np.asarray(lo, dtype=float), np.asarray(hi, dtype=float)
    dim, size, centre = lo.size, float(np.max(hi - lo)), 0.5 * (lo + hi)
    for field, kind, v in _placed(effects):
        if kind == "radius":
            check_radius(field, v, size, where)
            continue
        n = 2 * dim if kind == "box" else dim
        if len(v) != n:
            raise ParameterError(field, f"{field} = {v} has {len(v)} components, but the domain is {dim}D{where}: "
                                        f"it needs {n}")
        if kind == "box":
            check_reach(f"{field}[0:{dim}]", v[:dim], centre, size, where)
            check_reach(f"{field}[{dim}:{2 * dim}]", v[dim:], centre, size, where)
        elif kind == "point":
            check_reach(field, v, centre, size, where)
        elif kind == "displacement" and max(abs(c) for c in v) > REACH * size:
            raise ParameterError(field, f"{field} = {v}: a displacement larger than {REACH:g} domain sizes "
                                        f"({REACH * size:g}){where}")


def _check_nesting(data, limit=MAX_NESTING):
    """Refuse containers nested deeper than ``limit`` (iteratively: a deep structure cannot exhaust the stack)."""
    stack, seen = [(data, 1)], set()
    while stack:
        obj, depth = stack.pop()
        if depth > limit:
            raise ParameterError("scene", f"scene: nested deeper than {limit} levels (a scene needs at most 7)")
        if id(obj) in seen:  # shared or cyclic structures from Python are walked once
            continue
        seen.add(id(obj))
        children = obj.values() if isinstance(obj, dict) else obj
        stack.extend((c, depth + 1) for c in children if isinstance(c, (dict, list, tuple)))


# brackets and dots in the text of a scene, outside strings and comments, are checked before parsing: a deeply
# nested file never reaches the parsers' recursion, nor a long dotted key tomllib (whose memory grows as the
# square of its parts)
_SKIP_TOML = re.compile(r'"""(?:[^"\\]|\\.|"(?!""))*"""|\'\'\'.*?\'\'\'|"(?:[^"\\\n]|\\.)*"|\'[^\'\n]*\'|#[^\n]*',
                        re.S)
_SKIP_JSON = re.compile(r'"(?:[^"\\]|\\.)*"', re.S)
#: what opens and closes a table or an array; what ends a TOML key path (a number or a date between has one dot)
_OPENS, _CLOSES, _KEY_ENDS = [ord("["), ord("{")], [ord("]"), ord("}")], [ord(c) for c in "=\n,[]{}"]


def _check_text_nesting(text, kind):
    """Refuse a text whose brackets nest deeper than :data:`MAX_NESTING`, or (TOML) a dotted key path of more
    parts (JSON's key paths are its brackets), naming the line; a linear scan before any parsing."""
    codes = np.frombuffer(text.encode("utf-32-le", "surrogatepass"), dtype="<u4")
    outside = np.ones(codes.size, dtype=bool)
    for m in (_SKIP_TOML if kind == "TOML" else _SKIP_JSON).finditer(text):
        outside[m.start():m.end()] = False
    step = np.isin(codes, _OPENS).astype(np.int64) - np.isin(codes, _CLOSES)  # +1 where a bracket opens, -1 closes
    depth = np.cumsum(np.where(outside, step, 0))
    too_deep = np.flatnonzero(depth > MAX_NESTING)
    if too_deep.size:
        line = text.count("\n", 0, int(too_deep[0])) + 1
        raise ParameterError("scene", f"scene: its {kind} nests deeper than {MAX_NESTING} levels "
                                      f"(line {line}); a scene needs at most 7")
    at = np.flatnonzero((codes == ord(".")) & outside) if kind == "TOML" else np.zeros(0, dtype=np.intp)
    if at.size:
        key = np.searchsorted(np.flatnonzero(np.isin(codes, _KEY_ENDS) & outside), at)  # each dot's key path
        parts = np.bincount(key) + 1
        if parts.max() > MAX_NESTING:
            first = int(np.flatnonzero(parts > MAX_NESTING)[0])
            line = text.count("\n", 0, int(at[np.searchsorted(key, first)])) + 1
            raise ParameterError("scene", f"scene: a key path of {parts[first]} parts (line {line}) is "
                                          f"longer than the limit of {MAX_NESTING} (nested deeper than "
                                          f"{MAX_NESTING} levels; a scene needs at most 7)")


# --- TOML output (the subset scenes use: tables, arrays of tables, numbers, strings, arrays) ---------------------

def _toml_pairs(values) -> list:
    """The ``key = value`` lines of a table (a key that is not bare is quoted as a string is)."""
    return [f"{k if re.fullmatch(r'[A-Za-z0-9_-]+', k) else _toml_value(k)} = {_toml_value(v)}"
            for k, v in values.items()]


def _toml_value(v) -> str:
    """``v`` as a TOML value: a table inline, an array, or a number, boolean or string, which JSON writes as TOML
    does (shortest round-tripping floats; strings escaped alike but for DEL, which TOML escapes too)."""
    if isinstance(v, dict):
        return "{ " + ", ".join(_toml_pairs(v)) + " }"
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    if not isinstance(v, (bool, int, float, str, np.integer, np.floating)):
        raise ValueError(f"cannot write {show(v)} to TOML")
    # a non-finite number raises ValueError; ensure_ascii=False: no surrogate pairs, which TOML does not know
    return json.dumps(v, ensure_ascii=False, allow_nan=False, default=lambda x: x.item()).replace("\x7f", "\\u007f")


def _toml(data) -> str:
    lines = _toml_pairs({key: data[key] for key in ("name", "description") if key in data})
    for section in ("domain", "material", "solver"):
        lines += ["", f"[{section}]", *_toml_pairs(data[section])]
    for kind, value in data["effects"].items():
        for entry in value if _listed(kind) else [value]:
            lines += ["", f"[[effects.{kind}]]" if _listed(kind) else f"[effects.{kind}]", *_toml_pairs(entry)]
    return "\n".join(lines) + "\n"


def _path(path, argument="path", what="a file") -> Path:
    """``path`` as a Path if it is a str or an ``os.PathLike`` naming text (not bytes, not empty, no NUL)."""
    text = os.fspath(path) if isinstance(path, os.PathLike) else path
    if not isinstance(text, str):
        raise ParameterError(argument, f"{argument} must be {what} path (str or pathlib.Path), got {show(path)}")
    if not text.strip():
        raise ParameterError(argument, f"{argument} must not be empty")
    if "\0" in text:
        raise ParameterError(argument, f"{argument} must not contain a NUL character")
    return Path(text)


def _scene_path(path) -> Path:
    path = _path(path, "path", "a scene file")
    if path.suffix not in (".toml", ".json"):
        raise ParameterError("path", f"path: a scene file must end in .toml or .json, got {path.name!r}")
    return path


# --- the scene ---------------------------------------------------------------------------------------------------

class Scene:
    """A checked scene: dictionaries as in a scene file, missing optional fields set to their defaults (so
    :meth:`to_dict` is the complete scene); ``None`` means "the default" for the keyword arguments only.
    ``base_dir``: where a ``file`` domain's relative path starts; ``notes``: what :meth:`build_mesh` said."""

    def __init__(self, *, domain=None, material=None, effects=None, solver=None, name="scene", description="",
                 base_dir=None):
        self.name = string("name", name)
        self.description = string("description", description)
        self.domain = _check_domain(domain if domain is not None else {"shape": "rectangle"})
        self.material = _check_material(material)
        self.effects = _check_effects(effects if effects is not None else {}, self.dim)
        self.solver = _check_solver(solver if solver is not None else {})
        _check_2d_only(self.effects, self.dim, f", domain.shape = {self.domain['shape']!r}")
        box = _domain_box(self.domain)
        if box is not None:
            _check_reach(self.effects, *box)
        self.base_dir = None if base_dir is None else _path(base_dir, "base_dir", "a folder")
        self.notes = []

    # ------------------------------------------------------------------ constructors and output
    @classmethod
    def from_dict(cls, data, base_dir=None) -> "Scene":
        data = table("scene", data)
        _check_nesting(data)
        table("scene", data, ("name", "description", "domain", "material", "effects", "solver"))
        for key in ("domain", "material", "effects", "solver"):
            if key in data and data[key] is None:
                raise ParameterError(key,
                                     f"{key} must be a table (a dict), got None (leave {key} out for the defaults)")
        # the checks build new containers throughout, so the scene shares nothing with ``data``
        return cls(**data, base_dir=base_dir)

    def to_dict(self) -> dict:
        out = {"name": self.name}
        if self.description:
            out["description"] = self.description
        return out | {k: copy.deepcopy(getattr(self, k)) for k in ("domain", "material", "effects", "solver")}

    @classmethod
    def from_toml(cls, text, base_dir=None) -> "Scene":
        import tomllib  # deferred: only scene text needs it (a test keeps `import tissuefem` from loading it)

        return cls._parse(tomllib.loads, "TOML", text, base_dir)

    @classmethod
    def from_json(cls, text, base_dir=None) -> "Scene":
        return cls._parse(json.loads, "JSON", text, base_dir)

    @classmethod
    def _parse(cls, loads, kind, text, base_dir):
        if not isinstance(text, str):  # a file's bytes are decoded by load
            raise ParameterError("scene", f"scene: the {kind} text must be a string, got {show(text)}")
        if len(text) > MAX_SCENE_BYTES:
            raise ParameterError("scene",
                                 f"scene: {len(text)} characters, more than the {MAX_SCENE_BYTES} a scene may have")
        _check_text_nesting(text, kind)
        try:
            data = loads(text)
        except ValueError as err:  # TOMLDecodeError, JSONDecodeError, an integer of too many digits
            message = " ".join(str(err).split())
            raise ParameterError("scene", f"scene: not valid {kind}: {message}") from None
        return cls.from_dict(data, base_dir)

    def to_toml(self) -> str:
        return _toml(self.to_dict())

    def to_json(self) -> str:
        return json.dumps(self.to_dict(), indent=2) + "\n"

    @classmethod
    def load(cls, path) -> "Scene":
        """Read a scene from a ``.toml`` or ``.json`` file (UTF-8, at most :data:`MAX_SCENE_BYTES`)."""
        path = _scene_path(path)
        file = f"path: scene file {str(path)!r}"
        try:
            if path.exists() and not path.is_file():  # a folder, a pipe or a device (a pipe would block the read)
                raise ParameterError("path", f"{file} is not a regular file")
            with open(path, "rb") as f:
                data = f.read(MAX_SCENE_BYTES + 1)
        except OSError as err:  # missing, unreadable, a name too long for the system
            raise ParameterError("path", f"{file} cannot be read: {err.strerror or err}") from None
        if len(data) > MAX_SCENE_BYTES:
            raise ParameterError("path", f"{file} is larger than {MAX_SCENE_BYTES} bytes")
        try:
            text = data.decode("utf-8-sig")  # an editor's byte-order mark is harmless
        except UnicodeDecodeError as err:
            raise ParameterError("path", f"{file} is not UTF-8 text (byte {err.start})") from None
        return (cls.from_toml if path.suffix == ".toml" else cls.from_json)(text, base_dir=path.parent)

    def save(self, path) -> None:
        """Write the scene to a ``.toml`` or ``.json`` file that :meth:`load` reads back as this very scene (checked
        first; the file is replaced in one step, so a failure leaves it as it was)."""
        path = _scene_path(path)
        toml = path.suffix == ".toml"
        text = self.to_toml() if toml else self.to_json()
        if (Scene.from_toml if toml else Scene.from_json)(text) != self:
            raise ParameterError("scene",
                                 "scene: the written text would not read back as the same scene (please report this)")
        temporary = path.with_name(f".{path.name}.{os.getpid()}.tmp")
        try:
            if path.exists() and not path.is_file():  # a folder (os.replace would refuse it less clearly)
                raise ParameterError("path", f"path: {str(path)!r} is not a regular file, so no scene is written there")
            temporary.write_text(text, encoding="utf-8")
            os.replace(temporary, path)
        except OSError as err:  # a missing folder, no permission, a name too long for the system
            with contextlib.suppress(OSError):
                temporary.unlink()
            raise ParameterError("path", f"path: scene file {str(path)!r} cannot be written: "
                                         f"{err.strerror or err}") from None

    def __eq__(self, other):
        return isinstance(other, Scene) and self.to_dict() == other.to_dict()

    def __repr__(self):
        return f"Scene({self.name!r}: {self.domain['shape']}, {self.material['model']}, effects {list(self.effects)})"

    # ------------------------------------------------------------------ building
    @property
    def dynamic(self) -> bool:
        return "inertia" in self.effects

    @property
    def dim(self):
        """The dimension of the scene's mesh: 2 (triangles), 3 (tetrahedra), or ``None`` for a file not read yet."""
        return {"block": 3, "file": None}.get(self.domain["shape"], 2)

    def build_mesh(self):
        """The domain's mesh. For a ``file`` domain, the scene's points and radii are checked against its size here,
        and its effects against its dimension."""
        d = self.domain
        self.notes = []
        if d["shape"] in _MESHERS:  # each generator takes the domain's fields by name ("triangles": n_triangles)
            return _MESHERS[d["shape"]](**{("n_triangles" if k == "triangles" else k): v
                                           for k, v in d.items() if k != "shape"})
        path = Path(d["path"]) if self.base_dir is None else self.base_dir / d["path"]
        mesh, notes, dropped = _read_mesh(path, d["scale"], d["path"])
        where = f", the mesh read from {d['path']!r}"
        _check_2d_only(self.effects, mesh.p.shape[0], where)
        _check_reach(self.effects, mesh.p.min(axis=1), mesh.p.max(axis=1), f" ({where[2:]})")
        if dropped:
            noun = _ELEMENT_NOUN[mesh.p.shape[0]]
            for i, h in enumerate(self.effects.get("handles", [])):
                if isinstance(h["region"], dict) and "nodes" in h["region"]:
                    raise ParameterError(f"effects.handles[{i}].region.nodes",
                                         f"effects.handles[{i}].region.nodes: the mesh file has nodes in no {noun}, "
                                         "which are dropped and the rest renumbered, so node indices would point at "
                                         "other nodes; select the nodes with a box or near a point instead")
        self.notes = notes
        return mesh

    def build_material(self):
        m = self.material
        mat = make_material(m["model"], m["youngs_modulus"], m["poisson_ratio"])
        inv = self.effects.get("inversion", {})
        if inv.get("method") == "itf" and m["model"] != "neo-hookean":
            raise ParameterError("effects.inversion.method",
                                 "effects.inversion.method: 'itf' clamps the ln J model only "
                                 f"(material.model = 'neo-hookean'), got {m['model']!r}; use 'projected'")
        if inv.get("method") == "itf":
            return ITFClamped(mat, threshold=inv["threshold"])
        return ProjectedTangent(mat, adaptive=True) if inv else mat


# --- mesh files --------------------------------------------------------------------------------------------------

#: the cells a mesh file may hold: 3-node triangles or 4-node tetrahedra, and cells of lower dimension (groups: a
#: tetrahedron mesh's triangles, lines, vertices)
_CELLS_ALLOWED = ("tetra", "triangle", "line", "vertex")
#: what a mesh of each dimension is made of, in notes and refusals
_ELEMENT_NOUN = {2: "triangle", 3: "tetrahedron"}


def _mesh_error(message) -> ParameterError:
    """The refusal of a mesh file: a ``ParameterError`` naming ``domain.path`` (the file a scene names)."""
    return ParameterError("domain.path", f"domain.path: {message}")


def _quietly(path, read, *args):
    """``read(*args)`` with a mesh reader's printing and logging kept off the terminal. Its failure, even the
    ``sys.exit(1)`` meshio calls on a file it cannot read, becomes a ``ParameterError`` naming ``domain.path``
    (KeyboardInterrupt and GeneratorExit are left alone)."""
    sink, previous = io.StringIO(), logging.root.manager.disable
    logging.disable(logging.CRITICAL)
    try:
        with contextlib.redirect_stdout(sink), contextlib.redirect_stderr(sink):
            return read(*args)
    except (Exception, SystemExit) as err:
        said = " ".join((str(err) if not isinstance(err, SystemExit) else "").split())
        said = (said or " ".join(sink.getvalue().split()) or type(err).__name__).replace(str(path), path.name)
        said = said[:300] + " ..." if len(said) > 300 else said
        raise _mesh_error(f"could not read {path.name!r} as a mesh: {said}") from None
    finally:
        logging.disable(previous)


def _read_mesh(path, scale, label):
    """``(mesh, notes, dropped)``: the mesh of a file, what reading it changed (its tetrahedra listed left-handed,
    reoriented; its nodes in no element, dropped), said of ``label``, and whether nodes were dropped."""
    path = Path(path)
    name = path.name
    try:
        if not path.exists():
            raise _mesh_error(f"no mesh file {name!r} (looked in the scene's folder)")
        if not path.is_file():
            raise _mesh_error(f"{name!r} is not a regular file")
        size = path.stat().st_size
    except OSError as err:
        raise _mesh_error(f"{name!r} cannot be read: {err.strerror or err}") from None
    if size > MAX_MESH_FILE_BYTES:
        raise _mesh_error(f"{name!r} has {size} bytes, more than the {MAX_MESH_FILE_BYTES} a mesh file "
                         "may have")
    import meshio  # deferred: only mesh files need it, and it is slow to import
    from skfem.io.meshio import from_meshio

    m = _quietly(path, meshio.read, str(path))
    counts = collections.Counter()
    for block in m.cells:
        counts[block.type] += len(block.data)
    holds = ", ".join(f"{n} {kind}" for kind, n in sorted(counts.items())) or "no cells at all"
    foreign = sorted(set(counts) - set(_CELLS_ALLOWED))
    kind = "tetra" if counts.get("tetra", 0) else "triangle"
    if foreign or counts.get(kind, 0) == 0:
        why = (f"cells of type {foreign} are neither 3-node triangles nor 4-node tetrahedra" if foreign
               else "it has no triangles and no tetrahedra")
        raise _mesh_error(f"{name!r} holds {holds} cells: {why}; only meshes of 3-node triangles (2D) or 4-node "
                         "tetrahedra (3D) are read (cells of lower dimension may come with them, naming groups)")
    dim, nouns = (3, "tetrahedra") if kind == "tetra" else (2, "triangles")
    if counts[kind] > MAX_TRIANGLES:
        raise _mesh_error(f"{name!r} holds {counts[kind]} {nouns}, more than {MAX_TRIANGLES}")
    points = np.asarray(m.points)
    if points.dtype.kind not in "iuf" or points.ndim != 2 or points.shape[1] not in (dim, 3) or points.shape[0] == 0:
        expected = "3D coordinates" if dim == 3 else "2D (or planar 3D) coordinates"
        raise _mesh_error(f"{name!r} holds {nouns} and points of shape {points.shape} and dtype {points.dtype}; "
                         f"expected {expected}")
    bad = np.flatnonzero(~np.isfinite(points).all(axis=1))
    if bad.size:
        raise _mesh_error(f"{name!r}: nodes {meshes.index_list(bad)} have non-finite coordinates")
    if dim == 2 and points.shape[1] == 3:
        off = np.flatnonzero(points[:, 2] != 0)
        if off.size:
            raise _mesh_error(f"{name!r} is not planar: nodes {meshes.index_list(off)} (0-based) have a "
                             f"third coordinate other than 0 (up to |z| = {np.abs(points[off, 2]).max():g}); a mesh "
                             "of triangles is read as 2D, never flattened (a 3D body is a mesh of tetrahedra)")
    written = np.concatenate([np.asarray(b.data).T for b in m.cells if b.type == kind], axis=1)
    if written.dtype.kind not in "iu":
        raise _mesh_error(f"{name!r} holds {nouns} with non-integer node numbers ({written.dtype})")
    p = np.array(points[:, :dim].T, dtype=np.float64) * scale
    t, flipped = written, np.zeros(0, dtype=np.int64)
    if dim == 3 and written.min() >= 0 and written.max() < p.shape[1]:
        # a file's vertex order is a convention (gmsh's tetrahedra are right-handed, a sorted one's are not):
        # a left-handed tetrahedron is the same tetrahedron with two vertices swapped; overlaps are refused below
        flipped = np.flatnonzero(meshes.signed_volumes(types.SimpleNamespace(p=p, t=written)) < 0)
        t = written.copy()
        t[1, flipped], t[2, flipped] = written[2, flipped], written[1, flipped]
    try:  # check_mesh's refusal names the file and how its nodes are numbered; its field is domain.path
        p, t = meshes.check_mesh(p, t, f"domain.path: {name!r} (0-based node numbers, after scaling)",
                                 unused_nodes="ignore")
        named = _quietly(path, from_meshio, m)  # boundaries from physical groups or cell sets
        kept = np.unique(t)  # the nodes in no element dropped, the rest renumbered in their order
        new_index = np.full(p.shape[1], -1, dtype=np.int64)
        new_index[kept] = np.arange(kept.size)
        # as checked above (scaled, a 2D file's z dropped; triangles sorted as scikit-fem does)
        mesh = _new_mesh(np.ascontiguousarray(p[:, kept]), new_index[t])
        boundaries = {group: _facet_index(mesh, new_index[np.asarray(named.facets)[:, np.asarray(facets)]], name)
                      for group, facets in (named.boundaries or {}).items()}
        boundaries.update(_skfem_boundaries(m, kind, new_index[written], mesh, name))
        mesh = _new_mesh(mesh.p, mesh.t, _boundaries=boundaries or None, _subdomains=named.subdomains)
        meshes.check_mesh(mesh.p, mesh.t, f"domain.path: {name!r}")
    except ParameterError as err:
        raise ParameterError("domain.path", str(err)) from None
    dropped, notes = np.flatnonzero(new_index < 0), []
    if flipped.size:
        notes.append(f"domain.path: {label!r}: {flipped.size} tetrahedra listed with left-handed vertices (0-based "
                     f"{meshes.index_list(flipped)}) were reoriented by swapping two vertices (the same tetrahedra)")
    if dropped.size:
        notes.append(f"domain.path: {label!r}: dropped {dropped.size} node(s) that belong to no {_ELEMENT_NOUN[dim]} "
                     f"(0-based {meshes.index_list(dropped)}); the other nodes were renumbered in their order")
    return mesh, notes, dropped.size > 0


def _new_mesh(p, t, **options):
    """A scikit-fem mesh of the points' dimension: triangles sorted as scikit-fem does (their orientation is
    arbitrary), tetrahedra as given (right-handed)."""
    if np.shape(p)[0] == 3:
        return skfem.MeshTet(p, t, sort_t=False, **options)
    return skfem.MeshTri(p, t, **options)


def _facet_index(mesh, nodes, name) -> np.ndarray:
    """Indices of the facets of ``mesh`` with the nodes ``nodes`` (``(2, k)`` edges, ``(3, k)`` triangles), in that
    order (``name``: the file's)."""
    facets = np.sort(np.asarray(mesh.facets, dtype=np.int64), axis=0)
    rows = facets.shape[0]
    wanted = np.sort(np.asarray(nodes, dtype=np.int64).reshape(rows, -1), axis=0)
    _, label = np.unique(np.concatenate([facets, wanted], axis=1), axis=1, return_inverse=True)
    label = np.asarray(label).ravel()
    owner = np.full(label.max(initial=-1) + 1, -1, dtype=np.int64)
    owner[label[:facets.shape[1]]] = np.arange(facets.shape[1])
    found = owner[label[facets.shape[1]:]]
    if np.any(found < 0):
        raise _mesh_error(f"{name!r}: a named boundary of the file lies on no facet of its elements (an edge of its "
                          "triangles, a face of its tetrahedra)")
    return found


def _skfem_boundaries(m, kind, t, mesh, name):
    """Boundaries scikit-fem wrote into the file (``skfem:b:NAME`` cell data), as facet indices of ``mesh``: bit
    flags of each element's local facets in the node order ``t`` *as written*, decoded here in that order
    (scikit-fem's reader sorts the nodes first, which picks other facets of elements not written sorted)."""
    local = np.asarray((skfem.refdom.RefTet if kind == "tetra" else skfem.refdom.RefTri).facets)
    blocks = [i for i, b in enumerate(m.cells) if b.type == kind]
    out = {}
    for key, data in (m.cell_data or {}).items():
        parts = key.split(":")
        if len(parts) != 3 or parts[:2] != ["skfem", "b"]:
            continue
        flags = np.concatenate([np.asarray(data[i]).ravel() for i in blocks]).astype(np.int64)
        if flags.size != t.shape[1]:
            raise _mesh_error(f"{name!r}: the boundary {parts[2]!r} of the file does not match its elements")
        nodes = [t[local[k]][:, (flags >> k) & 1 == 1] for k in range(local.shape[0])]
        out[parts[2]] = np.sort(_facet_index(mesh, np.concatenate(nodes, axis=1), name))
    return out


def read_mesh(path, scale=1.0, notes=None):
    """A mesh from a file meshio reads (gmsh ``.msh``, ``.vtu``, ``.vtk``, ...), coordinates times ``scale``: 2D
    from 3-node triangles in ``z = 0`` (a :class:`skfem.MeshTri`), 3D from 4-node tetrahedra (a
    :class:`skfem.MeshTet`; the triangles of such a file are its surface); physical groups of the facets (lines, the
    tetrahedra's triangles) become named boundaries. Other cells, and meshes beyond the size limits or that do not
    pass :func:`~tissuefem.engine.meshes.check_mesh`, raise a :class:`~tissuefem.engine.parameters.ParameterError`
    naming ``domain.path`` and the file (``path``, ``scale`` or ``notes`` for an argument of the wrong kind). Nodes
    in no element (gmsh writes an arc's centre as a node) are dropped and the rest renumbered in their order;
    tetrahedra listed left-handed are reoriented; a note saying so is appended to ``notes``."""
    path = _path(path, "path", "a mesh file")
    scale = _within("scale", scale, SIZE_RANGE)
    if notes is not None and not isinstance(notes, list):
        raise ParameterError("notes", f"notes must be a list (the notes are appended to it) or None, got {show(notes)}")
    mesh, said, _ = _read_mesh(path, scale, path.name)
    if notes is not None:
        notes.extend(said)
    return mesh


def demo_scene(n_triangles=400, dynamic=True) -> Scene:
    """A small ready-made scene: a 2 x 1 sheet of stable neo-Hookean tissue held on its left edge."""
    effects = {"handles": [{"name": "fixed", "region": "left"}]}
    if dynamic:
        effects["inertia"] = {"time_step": FRAME_BUDGET}
    return Scene(name="sheet", domain={"shape": "rectangle", "width": 2.0, "height": 1.0, "triangles": n_triangles},
                 material={"model": "stable-neo-hookean", "youngs_modulus": TISSUE_E, "poisson_ratio": TISSUE_NU},
                 effects=effects)


def flap_path(t) -> np.ndarray:
    """The standard flap's scripted drag: the right edge's displacement at time ``t`` (a slow loop, period 4-8 s)."""
    t = float(t)
    return np.array([0.3 * math.sin(math.pi * t / 2.0), 0.4 * math.sin(math.pi * t / 4.0)])


def flap_scene(n_triangles: int = 8000, model: str = "neo-hookean", dynamic: bool = True, rtol: float = 1e-6,
               linear_solver: str = "reuse") -> Scene:
    """The standard scene of the benchmarks and chapters 7-9: the flap ``[0, 2] x [0, 1]`` (E = 1000,
    nu = 0.3, rho0 = 1, plane strain) of about ``n_triangles``, its left edge ``fixed``, its right edge a
    ``handle`` that :func:`flap_path` carries along a slow loop; backward Euler with ``dt = 1/30``
    (``dynamic=False``: quasistatic); every frame solved to ``rtol`` with no wall-clock budget."""
    effects = {"handles": [{"name": "fixed", "region": "fixed"}, {"name": "handle", "region": "handle"}]}
    if dynamic:
        effects["inertia"] = {"time_step": FRAME_BUDGET}
    return Scene(name="standard flap",
                 domain={"shape": "flap", "width": 2.0, "height": 1.0, "triangles": int(n_triangles)},
                 material={"model": model, "youngs_modulus": TISSUE_E, "poisson_ratio": TISSUE_NU,
                           "density": TISSUE_DENSITY},
                 effects=effects, solver={"budget": 1e9, "rtol": rtol, "linear_solver": linear_solver})
