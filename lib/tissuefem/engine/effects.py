"""The effects a scene can name, and the one place where each becomes a term.

:data:`EFFECTS` maps an effect's name (a key of a scene's ``effects`` table) to an :class:`Effect`: how its
table is checked (``check(field, table) -> params``, refusals name the field: ``effects.probes[0].radius``)
and how its term is made (``build(model, params, scene) -> Term | list[Term] | None``; ``scene``: the scene
being built, for defaults from its material or domain, or ``None``). A new effect is a term and one
:func:`register` call::

    register("wind", check=lambda field, table: {...}, build=lambda model, params, scene: Load(...))

A model's keywords (``dt``, ``gravity``, ``fibers`` ...) go through the same factories
(:func:`keyword_terms`). Probes and sutures are *placed* by the simulation's operations (``add_probe``,
``suture``).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from . import meshes
from .constants import FRAME_BUDGET
from .contact import Contact, ContactSurface
from .parameters import (ACCELERATION_MAX, CONTACT_STIFFNESS_MAX, FAR, FIBER_STIFFNESS_RANGE, FORCE_MAX, RADIUS_RANGE,
                         TIME_STEP_RANGE, YOUNGS_MODULUS_RANGE, MAX_POINTS, ParameterError, check_bounded_vector,
                         check_contact_stiffness, check_list, check_penalty_stiffness, count_list, number, penalty,
                         points, require, string, table, vector)
from .terms import Fibers, Inertia, Load, Probe, Sutures, Term, refuse_3d, traction_vector

__all__ = ["Effect", "EFFECTS", "GRAVITY_DOWN", "register", "factory", "keyword_terms", "SkinContact",
           "median_segment", "youngs_modulus"]

# --------------------------------------------------------------------------------------------- the registry

@dataclass(frozen=True)
class Effect:
    """``listed``: a list of tables; ``placed``: by the simulation; ``check=None``: a model keyword only."""

    check: Callable | None
    build: Callable
    listed: bool = False
    placed: bool = False


EFFECTS: dict[str, Effect] = {}


def register(name, check, build, *, listed=False, placed=False) -> None:
    """Add (or replace) the effect ``name``: a scene may name it from now on."""
    if not isinstance(name, str) or not name.isidentifier():
        raise ParameterError("name", f"name must be an identifier, got {name!r}")
    EFFECTS[name] = Effect(check, build, listed, placed)


def factory(name, params, scene=None) -> Callable:
    """``model -> Term | list | None``: the effect ``name`` with checked ``params``; built for a ``scene``, a refusal
    is named after the scene's field (``effects.contact.distance``)."""
    effect = EFFECTS[name]

    def make(model):
        try:
            return effect.build(model, params, scene)
        except ParameterError as err:
            if scene is None or err.field.startswith("effects."):
                raise
            text = f"effects.{err}" if err.field.startswith(f"{name}.") else f"effects.{name}: {err}"
            raise ParameterError(f"effects.{err.field}", text) from None

    return make


# inertia: backward Euler -------------------------------------------------------------------------------------

def _check_inertia(field, e):
    e = table(field, e, ("time_step", "mass"))
    return {"time_step": number(f"{field}.time_step", e.get("time_step", FRAME_BUDGET), lo=TIME_STEP_RANGE[0],
                                hi=TIME_STEP_RANGE[1]),
            "mass": string(f"{field}.mass", e.get("mass", "lumped"), ("lumped", "consistent"))}


register("inertia", _check_inertia,
         lambda model, p, scene: Inertia(model.assembler, p["time_step"], model.density, p["mass"]))


# loads -------------------------------------------------------------------------------------------------------

def _body_load(model, name, per_area):
    """A load of ``per_area(model)`` per unit reference area (a body force ``(bx, by)``)."""
    def make(m):
        return m.assembler.body_force(per_area(m))
    return Load(name, make(model), make)


#: gravity's default acceleration: 9.81 down the y axis (its first two components on a 2D mesh)
GRAVITY_DOWN = (0.0, -9.81, 0.0)


def _check_gravity(field, e):
    e = table(field, e, ("acceleration",))
    return {"acceleration": vector(f"{field}.acceleration", e.get("acceleration", list(GRAVITY_DOWN[:2])),
                                   ACCELERATION_MAX)}


def _gravity(model, p, scene):
    g = check_bounded_vector("gravity", p.get("acceleration", GRAVITY_DOWN[:model.dim]), ACCELERATION_MAX, model.dim)
    return _body_load(model, "gravity", lambda m: m.density * g)


def _body_force(model, p, scene):
    b = check_bounded_vector("body_force", p["force"], FORCE_MAX, model.dim)
    return _body_load(model, "body force", lambda m: b)


def _check_traction(field, e):
    e = require(field, table(field, e, ("boundary", "traction")), ("boundary", "traction"))
    return {"boundary": string(f"{field}.boundary", e["boundary"], nonempty=True),
            "traction": vector(f"{field}.traction", e["traction"], FORCE_MAX)}


def _tractions(model, entries, scene):
    """All tractions as one load ``f_(a,i) = sum int_boundary N_a t_i dS``."""
    if not entries:
        return None

    def make(m):
        f = np.zeros(m.n_dofs)
        for e in entries:
            f += traction_vector(m.basis, e["boundary"], e["traction"])
        return f

    return Load("tractions", make(model), make)


register("gravity", _check_gravity, _gravity)
register("body_force", None, _body_force)
register("tractions", _check_traction, _tractions, listed=True)


# fibres ------------------------------------------------------------------------------------------------------

def _check_fibers(field, e):
    e = require(field, table(field, e, ("stiffness", "direction")), ("stiffness",))
    direction = e.get("direction", [1.0, 0.0])
    if isinstance(direction, str):
        string(f"{field}.direction", direction, ("fusiform",))
    else:
        direction = vector(f"{field}.direction", direction)
        if not any(direction):
            raise ParameterError(f"{field}.direction", f"{field}.direction must not be zero")
    return {"stiffness": number(f"{field}.stiffness", e["stiffness"], lo=0.0, hi=FIBER_STIFFNESS_RANGE[1]),
            "direction": direction}


def _fibers(model, p, scene):
    g = p["direction"]
    if isinstance(g, str) and g == "fusiform":  # along the muscle's mapped grid lines
        if scene is not None and scene.domain["shape"] != "fusiform":
            raise ParameterError("fibers.direction", "fibers.direction: 'fusiform' needs domain.shape = 'fusiform'")
        g = meshes.fusiform_fiber_field(model.mesh)
    return Fibers(model.assembler, p["stiffness"], g)


register("fibers", _check_fibers, _fibers)


# probes and sutures (placed by the simulation) ---------------------------------------------------------------

def youngs_modulus(model, scene=None) -> float:
    """The Young's modulus penalties are measured in: the ``scene``'s, else that of the model's Lamé parameters
    (``mu (3 lam + 2 mu) / (lam + mu)``), else (a material without them) the largest accepted."""
    if scene is not None:
        return scene.material["youngs_modulus"]
    lam, mu = getattr(model.material, "lam", None), getattr(model.material, "mu", None)
    if lam is None or mu is None:
        return YOUNGS_MODULUS_RANGE[1]
    return mu * (3.0 * lam + 2.0 * mu) / (lam + mu)


def _check_probe(field, e):
    e = require(field, table(field, e, ("center", "radius", "stiffness")), ("center", "radius"))
    out = {"center": vector(f"{field}.center", e["center"]),
           "radius": number(f"{field}.radius", e["radius"], lo=RADIUS_RANGE[0] * meshes.SIZE_RANGE[0], hi=FAR)}
    if "stiffness" in e:
        out["stiffness"] = penalty(f"{field}.stiffness", e["stiffness"])
    return out


def _probes(model, entries, scene):
    """Rigid discs (balls on tetrahedra); default stiffness ``100 E / radius`` (penetration near 1 % of the radius at
    moderate pressure)."""
    out = []
    for i, p in enumerate(entries):
        p = dict(p)
        if scene is not None and p.get("stiffness") is None:
            p["stiffness"] = 100.0 * scene.material["youngs_modulus"] / p["radius"]
        probe = Probe(model.X, model.boundary_lengths, **p)
        check_penalty_stiffness(f"probes[{i}].stiffness", probe.stiffness, youngs_modulus(model, scene), probe.radius)
        out.append(probe)
    return out


def _check_suture(field, e):
    e = table(field, e, ("pairs", "stiffness", "tightness"))
    pairs = count_list(f"{field}.pairs", e.get("pairs"), "point pairs [[x1, y1], [x2, y2]]", MAX_POINTS)
    checked = [points(f"{field}.pairs[{j}]", pair, 2, 2) for j, pair in enumerate(pairs)]
    out = {"pairs": checked, "tightness": number(f"{field}.tightness", e.get("tightness", 1.0), lo=0.0, hi=1.0)}
    if "stiffness" in e:
        out["stiffness"] = penalty(f"{field}.stiffness", e["stiffness"], positive=True)
    return out


def _sutures(model, spec, scene):
    """Stitches given by their ends' nodes: ``pairs`` ``(2, k)`` or, with ``coefficients``, ``(2, c, k)``."""
    sutures = Sutures(model.X, spec["pairs"], spec["stiffness"], spec["gaps"], spec.get("tightness", 0.0),
                      coefficients=spec.get("coefficients"))
    check_penalty_stiffness("sutures.stiffness", sutures.k.max(), youngs_modulus(model, scene), positive=True)
    return sutures


register("probes", _check_probe, _probes, listed=True, placed=True)
register("sutures", _check_suture, _sutures, listed=True, placed=True)


# self-contact ------------------------------------------------------------------------------------------------

#: the default depth of the contact skin, in the median length of the surface's segments, and its stiffness (a
#: pressure), in Young's moduli
CONTACT_DISTANCE, CONTACT_STIFFNESS = 0.25, 1.0


def median_segment(surface, p) -> float:
    """The median length of the segments of a contact surface, at the node positions ``p``."""
    ends = surface.segment_positions(p)
    return float(np.median(np.hypot(*(ends[:, 1] - ends[:, 0]).T)))


class SkinContact(Contact):
    """Self-contact that keeps its settings across cuts, on the surface the change knows
    (:meth:`~tissuefem.engine.meshes.MeshMap.contact_surface`, else the mesh's boundary). ``default`` (no depth
    given): the skin must stay thin against the segments, and a cut leaves short ones, so after a remap the depth
    shrinks to half their median length (never past the starting depth ``base``)."""

    def __init__(self, X, surface, distance, stiffness, *, default=False, base=None):
        self.default, self.base = default, distance if base is None else base
        super().__init__(X, surface, distance, stiffness)

    def remap(self, meshmap):
        p = np.asarray(meshmap.mesh.p, dtype=float)
        surface = meshmap.contact_surface() or ContactSurface.from_mesh(meshmap.mesh)
        distance = min(self.base, 0.5 * median_segment(surface, p)) if self.default else self.base
        return SkinContact(p, surface, distance, self.stiffness, default=self.default, base=self.base)


def _check_contact(field, e):
    e = table(field, e, ("distance", "stiffness"))
    out = {}
    if "distance" in e:
        out["distance"] = number(f"{field}.distance", e["distance"], positive=True, hi=FAR)
    if "stiffness" in e:
        out["stiffness"] = number(f"{field}.stiffness", e["stiffness"], positive=True,
                                  hi=CONTACT_STIFFNESS_MAX * YOUNGS_MODULUS_RANGE[1])  # against E: when built
    return out


def _contact(model, p, scene):
    """A scene's contact: the mesh's boundary, a skin of a quarter of its median segment and Young's modulus as the
    stiffness unless given. A model's ``contact`` keyword: ``distance, stiffness[, surface, skin]``, all given."""
    refuse_3d("contact", model.X)
    if scene is None:
        p = _keys("contact", p, ("distance", "stiffness"), ("surface", "skin"))
        surface = ContactSurface.from_mesh(model.mesh) if p.get("surface") is None else p["surface"]
        check_contact_stiffness("contact.stiffness", p["stiffness"], youngs_modulus(model))
        return Contact(model.X, surface, p["distance"], p["stiffness"], p.get("skin"))
    surface, default = ContactSurface.from_mesh(model.mesh), "distance" not in p
    # a skin deeper than half the median segment is refused by the term (named effects.contact.distance by factory)
    distance = CONTACT_DISTANCE * median_segment(surface, model.X) if default else p["distance"]
    stiffness = p.get("stiffness", CONTACT_STIFFNESS * scene.material["youngs_modulus"])
    check_contact_stiffness("contact.stiffness", stiffness, scene.material["youngs_modulus"])
    return SkinContact(model.X, surface, distance, stiffness, default=default)


register("contact", _check_contact, _contact)


# --------------------------------------------------------------------------------------------- model keywords

def _named_tractions(tractions) -> list:
    bad = ParameterError("tractions", f"tractions must be {{boundary: (tx, ty)}} or [(boundary, (tx, ty)), ...], "
                                      f"got {tractions!r:.200}")
    try:
        items = list(tractions.items() if isinstance(tractions, dict) else tractions)
    except TypeError:
        raise bad from None
    out = []
    for i, item in enumerate(items):
        try:
            name, t = item
        except (TypeError, ValueError):
            raise bad from None
        out.append(_check_traction(f"tractions[{i}]", {"boundary": name, "traction": t}))  # as a scene's are
    return out


def _keys(field, spec, required, optional=()) -> dict:
    """``spec``: a dict with the ``required`` keys and no others than those and ``optional``."""
    return require(field, table(field, spec, required + optional), required)


def keyword_terms(*, dt=None, mass="lumped", gravity=None, body_force=None, tractions=None, fibers=None, probes=(),
                  sutures=None, contact=None) -> list:
    """The factories of a model's keywords (:class:`~tissuefem.engine.model.Model`) in build order: the effects'
    own, given the keywords' tables (their keys checked here, their values when the terms are made)."""
    probes = check_list("probes", probes, "dicts (center, radius, stiffness[, label])")
    if fibers is not None:
        try:
            stiffness, directions = fibers
        except (TypeError, ValueError):
            raise ParameterError("fibers", f"fibers must be (stiffness, directions), got {fibers!r}") from None
        fibers = {"stiffness": stiffness, "direction": directions}
    params = {"fibers": fibers,
              "inertia": None if dt is None else {"time_step": dt, "mass": mass},
              "probes": [_keys(f"probes[{i}]", spec, ("center", "radius", "stiffness"), ("label", "smoothing"))
                         for i, spec in enumerate(probes)] or None,
              "sutures": None if sutures is None else _keys("sutures", sutures, ("pairs", "stiffness", "gaps"),
                                                            ("tightness", "coefficients")),
              "contact": contact,
              "gravity": None if gravity is None else {"acceleration": gravity},
              "body_force": None if body_force is None else {"force": body_force},
              "tractions": None if tractions is None else _named_tractions(tractions)}
    return [factory(name, p) for name, p in params.items() if p is not None]


def as_terms(made) -> list[Term]:
    """A factory's result as a list of terms (``None``: none)."""
    return [] if made is None else list(made) if isinstance(made, (list, tuple)) else [made]
