"""The running simulation: a scene built, stepped frame by frame, and operated on between frames.

:class:`Simulation` builds a :class:`~tissuefem.surgery.scene.Scene` (mesh, the model of its named effects, its
excisions and incisions, the real-time solver) and offers the operations between frames: grab, drag, release, probe,
cut, excise and suture. A probe or a suture is a term added to the model; a cut or an excision carries the model, its
terms, handles and state to the new mesh (:meth:`~tissuefem.engine.model.Model.remapped`). A handle's *target* is a
displacement everywhere: a translation ``(dx, dy)`` of the held reference points, or a map ``X -> x``.
"""

from __future__ import annotations

import contextlib
import dataclasses
import time

import numpy as np

from ..engine import meshes
from ..engine.effects import EFFECTS, factory
from ..engine.meshes import MeshMap
from ..engine.model import Handle, Model, region_nodes
from ..engine.parameters import (PENALTY_MAX, ParameterError, check_count, check_penalty_stiffness, check_radius,
                                 check_reach, check_vector, number, string)
from ..engine.realtime import RealtimeSolver
from ..engine.terms import Sutures, refuse_3d
from . import element_cuts, topology
from .geometry import check_points
from .scene import Scene
from .surfaces import contact_surface

__all__ = ["Simulation", "Stitches"]


class Simulation:
    """A scene, built and running: frames, and the surgical operations between them.

    ``clock``: seconds (tests pass a fake one); ``linear_solver`` overrides the scene's; ``constant_tangent``: run a
    quadratic model with the ``"constant"`` linear solver (one factorization per set of held dofs; ``False`` forces
    the general Newton loop, to measure what that saves); ``order``, ``intorder``: the model's elements (cuts and
    excisions need P1) and quadrature degree. A probe or sutures added or removed keep the running factorization
    (``"reuse..."`` linear solvers: CG's preconditioner until it is refreshed). ``keep_factorization``: after a cut
    or an excision too, the frames are preconditioned by the old factorization extended to the new nodes while a
    fresh one is made off the frame; off by default: measured, it pays only where a second core is free
    (docs/benchmarks.md, "Effect costs: what was tried").
    """

    def __init__(self, scene: Scene, *, clock=time.perf_counter, linear_solver=None, constant_tangent=True,
                 order: int = 1, intorder: int | None = None, keep_factorization: bool = False):
        if not isinstance(scene, Scene):
            raise ValueError(f"scene must be a Scene, got {scene!r}")
        self.scene, self.clock = scene, clock
        self._linear_choice = linear_solver or scene.solver["linear_solver"]
        self._constant_tangent = bool(constant_tangent)
        self._keep_factorization = bool(keep_factorization)
        self.material = scene.build_material()
        self.model = _scene_model(scene, self.material, order, intorder)
        self._grab_count = self._probe_count = 0
        #: pieces lifted out because nothing held them (quasistatic scenes only; see _carried)
        self.removed_pieces = 0
        self._regions = {}  # where the material of each element cut through lies (its weight: model.weights)
        self.solver = None
        for kind, key in (("excisions", "polygon"), ("incisions", "path")):
            for i, e in enumerate(scene.effects.get(kind, [])):
                operation = _OPERATIONS[kind][e.get("method", "elements")]
                self._apply_edit(operation, np.asarray(e[key], dtype=float), f"effects.{kind}[{i}]")
        if not self.dynamic:
            _, pieces = _loose_elements(self.mesh, np.arange(self.mesh.nvertices), None, self.model.handles)
            if pieces:
                raise ValueError(f"effects.handles: {pieces} piece(s) of the domain are held by nothing; a quasistatic "
                                 "scene must hold every piece (or it floats and has no equilibrium)")
        self._new_solver()
        for i, p in enumerate(scene.effects.get("probes", [])):
            self.add_probe(p["center"], p["radius"], p.get("stiffness"), _field=f"effects.probes[{i}]")
        for i, s in enumerate(scene.effects.get("sutures", [])):
            self.suture(s["pairs"], stiffness=s.get("stiffness"), tightness=s["tightness"],
                        _field=f"effects.sutures[{i}]")

    # ------------------------------------------------------------------ building
    dynamic = property(lambda self: self.scene.dynamic, doc="Whether the scene names inertia.")
    mesh = property(lambda self: self.model.mesh, doc="The current mesh (cuts and excisions change it).")
    order = property(lambda self: self.model.order, doc="The elements' order (1: P1).")

    @property
    def handles(self) -> dict:
        """The handles holding the tissue, by name (the model owns them)."""
        return {h.name: h for h in self.model.handles}

    def _new_solver(self, state=None, parent=None) -> None:
        """A real-time solver for the model, with the running one's state (or ``state``: ``u, v, v_previous``) and
        its kept factorization (``parent``: the old dof of each new dof; ``None``: the same dofs)."""
        model, settings, old, choice = self.model, self.scene.solver, self.solver, self._linear_choice
        if model.quadratic and self._constant_tangent and isinstance(choice, str):
            # a constant Hessian: one factorization per held set is exact (with the named direct backend)
            base = choice.removeprefix("reuse-")
            choice = "constant" if base in ("reuse", "direct", "background", "superlu") else f"constant-{base}"
        new = self.solver = RealtimeSolver(model, linear_solver=choice, budget=settings["budget"],
                                           rtol=settings["rtol"], clock=self.clock,
                                           max_iterations=settings["max_iterations"])
        if old is None:
            return
        u, v, v_previous = state if state is not None else (old.u.copy(), old.v.copy(), old.v_previous)
        new.set_state(u, v if model.dynamic else None, v_previous=v_previous if model.dynamic else None,
                      time_=old.time, steps=old.steps)  # time and frames go on
        new.budget, new.launch, new.last_report = old.budget, old.launch, old.last_report
        if old.dt is not None:
            new.dt = old.dt
        new.costs.update(old.costs)  # what the work cost lately: the next frame keeps its budget
        if parent is None and old.model.n_dofs == model.n_dofs:  # the same dofs: the factorization fits
            new.linear.carry(old.linear, np.arange(model.n_dofs))
        elif self._keep_factorization and parent is not None:
            new.linear.carry(old.linear, parent)

    def _set_terms(self, terms) -> None:
        """The running model with ``terms`` (a probe or stitches added or removed), and a solver for it."""
        self.model.set_terms(terms)
        self._new_solver()

    @contextlib.contextmanager
    def _transaction(self):
        """Apply a change completely or not at all: on any error, everything is put back as it was. A step running
        off the frame is committed first (the change must not happen under it)."""
        if self.solver is not None:
            self.solver.settle()
        model, solver, terms = self.model, self.solver, list(self.model.terms)
        saved = (self._grab_count, self._probe_count, self.removed_pieces, self._regions)
        handles = [(h, h.target) for h in model.handles]
        try:
            yield
        except BaseException:
            self.model, self.solver = model, solver
            (self._grab_count, self._probe_count, self.removed_pieces, self._regions) = saved
            if model.terms != terms:
                model.set_terms(terms)
            model.handles[:] = [h for h, _ in handles]
            for h, target in handles:
                h.target = target
            raise

    def _check_held(self, handles):  # a quasistatic scene without a handle floats: K is singular
        if not self.dynamic and not handles:
            raise ValueError("handles: a quasistatic scene needs at least one handle; this change would leave none")

    # ------------------------------------------------------------------ frames
    @property
    def terms(self) -> list[str]:
        """The terms the model evaluates, with the inversion handling named after the elastic term it wraps."""
        names = self.model.term_names
        if "inversion" in self.scene.effects:  # the elastic term's material is wrapped, not a term of its own
            i = names.index("elastic") + 1
            names = names[:i] + [f"inversion ({self.scene.effects['inversion']['method']})"] + names[i:]
        return names

    u = property(lambda self: self.solver.u, doc="The displacement (a dof vector).")
    v = property(lambda self: self.solver.v, doc="The velocity (a dof vector).")
    frames = property(lambda self: self.solver.steps, doc="Frames run so far.")
    time = property(lambda self: self.solver.time, doc="Simulated seconds so far.")

    def frame(self, targets=None):
        """One frame. ``targets``: ``{handle name: translation (dx, dy) or map}`` (others keep theirs); a refused
        target changes nothing."""
        if targets is not None and not isinstance(targets, dict):
            raise ValueError(f"targets must be a dict {{handle name: target}}, got {targets!r}")
        return self.solver.frame(targets or None)

    def run(self, frames: int, targets=None):
        """Run ``frames`` frames (an integer >= 0, with the same ``targets`` for each); return the reports."""
        frames = check_count("frames", frames, 0)
        return [self.frame(targets) for _ in range(frames)]

    def _point(self, field, point) -> np.ndarray:
        """A finite point of the mesh's dimension within ``REACH`` domain sizes of the domain's centre (the model's
        reference box)."""
        return check_reach(field, check_vector(field, point, self.model.dim), self.model.middle, self.model.size)

    def _radius(self, field, radius) -> float:
        """A radius within ``RADIUS_RANGE`` domain sizes: what a penalty ``~ 1 / r^2`` can be computed for."""
        return check_radius(field, number(field, radius, positive=True), self.model.size)

    @property
    def picture(self):
        """What to draw (:class:`~tissuefem.surgery.element_cuts.Picture`, built once per mesh)."""
        if getattr(self, "_picture", (None,))[0] is not self.mesh:
            self._picture = (self.mesh, element_cuts.picture(self.mesh, self._regions))
        return self._picture[1]

    def positions(self) -> np.ndarray:
        """Deformed node positions ``x = X + u`` ``(2, n_nodes)``."""
        return self.model.positions(self.solver.u)

    def total_mass(self) -> float:
        return self.model.total_mass()

    def momentum(self) -> np.ndarray:
        return self.solver.momentum()

    def pieces(self) -> int:
        """How many separate pieces the tissue is in."""
        return topology.connected_components(self.mesh.t, self.mesh.nvertices)[0]

    def tension(self) -> np.ndarray:
        """Largest principal Cauchy stress per element (see :meth:`tissuefem.engine.model.Model.tension`)."""
        return self.model.tension(self.solver.u)

    # ------------------------------------------------------------------ handles: pull and drag
    def grab(self, point, radius=None) -> str:
        """Grab the nodes within ``radius`` (default 1.5 mean edge lengths) of ``point`` (deformed coordinates);
        returns the handle's name. The nodes stay put until :meth:`drag` moves the pointer."""
        radius = 1.5 * meshes.mean_edge_length(self.mesh) if radius is None else self._radius("radius", radius)
        point = self._point("point", point)
        if self.order != 1:
            raise ValueError("grab: grabbing needs P1 elements (order=1)")
        self.solver.settle()  # a new handle changes the model: not under a running step
        gap = self.positions() - point[:, None]
        distance = np.hypot(*gap) if gap.shape[0] == 2 else np.sqrt(np.sum(gap * gap, axis=0))
        nodes = np.flatnonzero(distance <= radius)
        if nodes.size == 0:
            raise ValueError(f"point {point.tolist()}: no tissue within radius {radius:g}")
        count = self._grab_count + 1
        while f"grab{count}" in self.handles:  # never replace a scene's handle of the same name
            count += 1
        u = self.solver.u.reshape(-1, self.model.dim).T
        self.model.add_handle(Handle(nodes, base=u[:, nodes].copy(), name=f"grab{count}", anchor=point))
        self._grab_count = count
        return f"grab{count}"

    def drag(self, name, point) -> None:
        """Move the pointer of a grab to ``point``: the handle's target becomes the offset from its grab point."""
        h, point = self.model.handle(name), self._point("point", point)
        h.move(point if h.anchor is None else point - h.anchor)

    def move_handle(self, name, target) -> None:
        """Set a handle's target (a translation or a map), checked; takes effect at the next frame."""
        self.model.handle(name).move(target)

    def release(self, name) -> None:
        """Let go of a handle. A quasistatic scene lifts out a piece nothing holds any more (it has no equilibrium,
        see `_carried`); a dynamic scene keeps it: it falls."""
        handle = self.model.handle(name)
        self._check_held([h for h in self.model.handles if h is not handle])
        if self.dynamic:
            self.solver.settle()
            self.model.remove_handle(name)
            return
        with self._transaction():
            self.model.remove_handle(name)
            stitches = self.model.sutures
            loose, pieces = _loose_elements(self.mesh, np.arange(self.mesh.nvertices),
                                            None if stitches is None else stitches.elements, self.model.handles,
                                            every_piece_loose=f"release({name!r})")
            if pieces:
                self._apply_edit(topology.excise, lambda centroids: loose.copy(), f"release({name!r})")
                self.removed_pieces += pieces

    # ------------------------------------------------------------------ probe
    def add_probe(self, center, radius, stiffness=None, _field="probe"):
        """Press a rigid disc (a tool tip) into the tissue; returns its label for :meth:`move_probe`. Default
        stiffness ``100 E / radius``: the penetration stays near 1 % of the radius under a moderate pressure."""
        center = self._point(f"{_field}.center", center).tolist()
        radius = self._radius(f"{_field}.radius", radius)  # in domain sizes: the default stiffness stays finite
        E = self.scene.material["youngs_modulus"]
        if stiffness is None:
            stiffness = number(f"{_field}.stiffness (default 100 E / radius)", 100.0 * E / radius, hi=PENALTY_MAX)
        else:
            stiffness = check_penalty_stiffness(f"{_field}.stiffness", stiffness, E, radius)
        label = f"probe{self._probe_count + 1}"
        spec = dict(center=center, radius=radius, stiffness=stiffness, label=label)
        with self._transaction():
            self._set_terms(self.model.terms + factory("probes", [spec])(self.model))
            self._probe_count += 1
        return label

    def _probe(self, label):
        for p in self.model.probes if isinstance(label, str) else ():  # labels are strings (not arrays, lists)
            if p.label == label:
                return p
        raise ValueError(f"no probe named {label!r:.100}; probes: {[p.label for p in self.model.probes]}")

    def move_probe(self, label, center) -> None:
        """Move the probe ``label`` to ``center`` (checked; a refusal keeps it where it was). The probe is part of
        the energy: a step running off the frame is committed first."""
        probe, center = self._probe(label), self._point("center", center)
        self.solver.settle()
        probe.move(center)

    def remove_probe(self, label) -> None:
        probe = self._probe(label)
        with self._transaction():
            self._set_terms([t for t in self.model.terms if t is not probe])

    # ------------------------------------------------------------------ topology changes
    def _apply_edit(self, operation, argument, field):
        """Apply a cut or an excision (all or nothing) and carry the model and the state to its mesh."""
        running = self.solver is not None
        try:
            edit = _edit(operation, self.mesh, argument, self.positions() if running else None, self.model.weights,
                         self._regions)
        except ValueError as err:
            text = str(err)  # named once: a message that starts with the field's name says it already
            raise ParameterError(field, text if text.startswith(field) else f"{field}: {text}") from None
        with self._transaction():
            edit, carried, pieces = _carried(edit, self.model, self._regions, keep_loose=self.dynamic)
            self.removed_pieces += pieces
            s = self.solver
            model, state = self.model.remapped(carried, () if not running else (s.u, s.v, s.v_previous))
            self._check_held(model.handles)
            self.model, self._regions = model, carried.regions
            if running:
                self._new_solver(state, carried.transfer_dofs(np.arange(2 * carried.n_old_nodes)))
        return edit

    def cut(self, polyline, method="elements"):
        """Incise along ``polyline`` (deformed coordinates, as drawn on the tissue now): through the elements
        (``method="elements"``, :func:`~tissuefem.surgery.element_cuts.cut_through`) or snapped to mesh edges
        (``"edges"``, :func:`~tissuefem.surgery.topology.incise`). Each copy of a node keeps its displacement and
        velocity. Returns the edit (a :class:`~tissuefem.engine.meshes.MeshMap`)."""
        refuse_3d("cut", self.model.X)  # cuts are 2D only for now
        operation = _OPERATIONS["incisions"][string("method", method, _OPERATIONS["incisions"])]
        points = check_points("polyline", polyline, 2)
        for i, q in enumerate(points):
            self._point(f"polyline[{i}]", q)
        return self._apply_edit(operation, points, "polyline")

    def excise(self, region, method="elements"):
        """Remove the tissue inside ``region``, a polygon in *reference* coordinates cut out along its outline
        (``method="elements"``) or the triangles whose centroid lies inside (``"edges"``), or a mask on centroids."""
        refuse_3d("excise", self.model.X)  # excisions are 2D only for now
        if callable(region):
            return self._apply_edit(topology.excise, region, "region")
        operation = _OPERATIONS["excisions"][string("method", method, _OPERATIONS["excisions"])]
        region = check_points("region", region, 3)
        for i, q in enumerate(region):
            self._point(f"region[{i}]", q)
        return self._apply_edit(operation, region, "region")

    # ------------------------------------------------------------------ sutures
    def suture(self, pairs, stiffness=None, tightness=1.0, _field="sutures"):
        """Tie pairs of points together with stiff springs (default stiffness 100 E per unit thickness).

        ``pairs``: point pairs ``[[[x1, y1], [x2, y2]], ...]`` in deformed coordinates (each moves with the element
        it lies in; off the tissue, with the nearest node), or node index pairs ``(2, k)``. The springs start slack
        and are tightened to ``tightness`` (1: closed). Returns the node carrying most of each end, ``(2, k)``.
        """
        E = self.scene.material["youngs_modulus"]
        k = 100.0 * E if stiffness is None else check_penalty_stiffness(f"{_field}.stiffness", stiffness, E,
                                                                        positive=True)
        spec = _new_stitches(self.mesh, self.positions(), pairs, k, _field, self._point, self.model.weights,
                             self._regions)
        k_new = spec["stiffness"].size
        tightness = number(f"{_field}.tightness", tightness, lo=0.0, hi=1.0)
        old = self.model.sutures
        if old is not None:  # the old stitches keep their gap when placed and their tightness
            spec = {key: np.concatenate([value, spec[key]], axis=1 if key == "barycentric" else -1)
                    for key, value in old.ends_spec().items()}
        with self._transaction():
            self._set_terms([t for t in self.model.terms if t is not old] + [Stitches(self.mesh, **spec)])
            total = spec["stiffness"].size
            if tightness > 0:
                self.tighten(tightness, stitches=np.arange(total - k_new, total))
        return self.model.sutures.pairs[:, -k_new:]

    def tighten(self, fraction, stitches=None) -> None:
        """Tighten the ``stitches`` (indices, default all): each keeps ``1 - fraction`` of its gap when placed."""
        if self.model.sutures is None:
            raise ValueError("tighten: there are no sutures")
        self.solver.settle()
        self.model.sutures.tighten(fraction, stitches)

    def suture_gaps(self) -> np.ndarray:
        """Distances between the sutured points (0 when closed)."""
        if self.model.sutures is None:
            return np.zeros(0)
        return self.model.sutures.distances(self.solver.u)


class Stitches(Sutures):
    """Sutures whose ends are points of the material: an element and barycentric weights per end,
    ``elements`` ``(2, k)`` and ``barycentric`` ``(2, k, 3)`` (``(2, k, 4)`` on tetrahedra), so that a cut carries each
    end to the copy of its element that holds it (:func:`~tissuefem.surgery.element_cuts.carry_points`)."""

    def __init__(self, mesh, elements, barycentric, stiffness, gaps, tightness):
        t = np.asarray(mesh.t)
        self.elements, self.barycentric = elements, barycentric
        super().__init__(np.asarray(mesh.p, dtype=float), np.stack([t[:, elements[0]], t[:, elements[1]]]),
                         stiffness, gaps, tightness, coefficients=barycentric.transpose(0, 2, 1))

    def ends_spec(self) -> dict:
        return {"elements": self.elements, "barycentric": self.barycentric, "stiffness": self.k, "gaps": self.gap0,
                "tightness": self.tightness}

    @staticmethod
    def carry(spec, edit, regions):
        """The stitches ``spec`` after ``edit``: each end stays at its point of the material (dropped with its
        element); ``None`` if none is left."""
        ends = [element_cuts.carry_points(edit, spec["elements"][s], spec["barycentric"][s], regions)
                for s in range(2)]
        keep = (ends[0] >= 0) & (ends[1] >= 0)
        if not np.any(keep):
            return None
        return {"elements": np.vstack([ends[0][keep], ends[1][keep]]), "barycentric": spec["barycentric"][:, keep],
                "gaps": spec["gaps"][:, keep], "stiffness": spec["stiffness"][keep],
                "tightness": spec["tightness"][keep]}

    def remap(self, meshmap):
        stages = getattr(meshmap, "stages", None) or ((meshmap, getattr(meshmap, "regions", None)),)
        spec = self.ends_spec()
        for edit, regions in stages:
            spec = self.carry(spec, edit, regions)
            if spec is None:
                return None
        return Stitches(meshmap.mesh, **spec)


@dataclasses.dataclass(frozen=True, kw_only=True)
class _Carried(MeshMap):
    """An edit as the model sees it: the material after it (``weights``, ``regions``: the contact surface is
    where the material ends), and the ``stages`` (edit, regions) that stitches are carried through."""

    regions: dict
    stages: tuple = ()

    def contact_surface(self):
        return contact_surface(self.mesh, self.weights, self.regions)


def _scene_model(scene, material, order, intorder) -> Model:
    """The model of a scene on its mesh: its handles, and a term for every effect of the registry it names
    (probes and sutures are placed afterwards, by the simulation's operations)."""
    mesh = scene.build_mesh()
    handles = []
    for i, h in enumerate(scene.effects.get("handles", [])):
        nodes = region_nodes(mesh, h["region"], f"effects.handles[{i}].region")
        handles.append(Handle(nodes, h.get("target"), name=h["name"]))  # none given: held where it is
    if not handles and not scene.dynamic:
        raise ValueError("effects.handles: a quasistatic scene needs at least one handle (e.g. a fixed edge), "
                         "or the body floats freely")
    if (scene.effects.get("excisions") or scene.effects.get("incisions")) and order != 1:
        raise ValueError("solver: excisions and incisions need P1 elements (order=1)")
    terms = [factory(name, params, scene) for name, params in scene.effects.items()
             if name in EFFECTS and not EFFECTS[name].placed]
    return Model(mesh, material, order=order, intorder=intorder, handles=handles, density=scene.material["density"],
                 terms=terms)


def _edit(operation, mesh, argument, positions, weights, regions):
    """The edit of ``mesh`` by ``operation``: a cut drawn on the tissue at ``positions``, an excision's outline in
    reference coordinates; a cut through the elements takes the material cut through so far."""
    if operation in (topology.excise, element_cuts.excise_through):
        positions = None
    if operation in (element_cuts.cut_through, element_cuts.excise_through):
        return operation(mesh, argument, positions, weights=weights, regions=regions)
    return operation(mesh, argument, positions)


def _carried(edit, model, regions, keep_loose):
    """``(edit, map, pieces)``: the edit, the map the model is carried by (the material's weights and regions after
    it, the stages of its stitches) and how many pieces were lifted out. Unless ``keep_loose`` (quasistatic scenes),
    a second excision lifts out the pieces nothing holds (no handle at a node with material there, no suture to a
    held piece): they have no equilibrium, and a surgeon lifts out what was cut free."""
    weights, regions = _material_after(edit, model.weights, regions)
    material = element_cuts.node_material(edit.mesh, regions)  # the virtual nodes hold nothing
    stages, pieces = [(edit, regions)], 0
    if not keep_loose:
        stitches = model.sutures
        ends = None if stitches is None else Stitches.carry(stitches.ends_spec(), edit, regions)
        loose, pieces = _loose_elements(edit.mesh, edit.parent, None if ends is None else ends["elements"],
                                        model.handles, material)
    if pieces:  # (none held at all: _check_held reports it)
        lift = topology.excise(edit.mesh, lambda centroids: loose.copy())
        edit = dataclasses.replace(lift, parent=edit.parent[lift.parent], elements=edit.elements[lift.elements],
                                   cut_edges=edit.cut_edges, n_old_nodes=edit.n_old_nodes,
                                   n_old_elements=edit.n_old_elements)
        kept = lift.elements  # the elements that stay, of those the edit made (a kept node keeps all of them)
        weights = None if weights is None else weights[kept]
        regions = {new: regions[old] for new, old in enumerate(kept.tolist()) if old in regions}
        material = None if material is None else material[lift.parent]
        stages.append((lift, regions))
    carried = _Carried(mesh=edit.mesh, parent=edit.parent, elements=edit.elements, n_old_nodes=edit.n_old_nodes,
                       n_old_elements=edit.n_old_elements, weights=weights, material=material, regions=regions,
                       stages=tuple(stages))
    return edit, carried, pieces


def _new_stitches(mesh, x, pairs, k, field, check_point, weights, regions) -> dict:
    """The stitches of :meth:`Simulation.suture`: each end an element and barycentric weights, ``elements``
    ``(2, k)``, ``barycentric`` ``(2, k, 3)`` (``(2, k, 4)`` on tetrahedra), with their ``gaps`` at the positions ``x``
    (pairs that tie a point to itself are left out); ``check_point(field, point)`` refuses points out of reach. On
    tetrahedra the ends are nodes: finding the element at a point is 2D only for now."""
    try:
        arr = np.asarray(pairs)
    except (TypeError, ValueError):
        raise ValueError(f"{field}.pairs must be point pairs shaped (k, 2, 2) or node index pairs shaped "
                         f"(2, k), got {pairs!r:.200}") from None
    t = np.asarray(mesh.t)
    if arr.dtype.kind in "iu" and arr.ndim == 2 and arr.shape[0] == 2:
        nodes = arr.astype(np.intp)
        if nodes.size == 0 or nodes.min() < 0 or nodes.max() >= mesh.nvertices:
            raise ValueError(f"{field}.pairs: node indices must be in 0..{mesh.nvertices - 1}")
        ends = [[_node_end(mesh, int(q)) for q in nodes[s]] for s in range(2)]
    else:
        if x.shape[0] != 2:
            raise ParameterError(f"{field}.pairs", f"{field}.pairs: stitches at points are 2D only for now (the mesh "
                                                   "has tetrahedra); give node index pairs shaped (2, k)")
        if arr.dtype.kind not in "iuf":  # booleans, strings, complex numbers: not points
            raise ValueError(f"{field}.pairs must be real point pairs shaped (k, 2, 2), got dtype {arr.dtype}")
        arr = arr.astype(float)
        if arr.ndim != 3 or arr.shape[1:] != (2, 2) or arr.shape[0] == 0 or not np.all(np.isfinite(arr)):
            raise ValueError(f"{field}.pairs must be point pairs shaped (k, 2, 2), got shape {arr.shape}")
        for j, pair in enumerate(arr):
            for i, q in enumerate(pair):
                check_point(f"{field}.pairs[{j}][{i}]", q)
        ends = [[_point_end(mesh, x, q[s], weights, regions) for q in arr] for s in range(2)]
    elements = np.array([[e for e, _ in side] for side in ends], dtype=np.int64).reshape(2, -1)
    bary = np.array([[w for _, w in side] for side in ends], dtype=float).reshape(2, -1, t.shape[0])
    at = np.einsum("skc,iskc->sik", bary, x[:, t[:, elements].transpose(1, 2, 0)])  # (2 ends, d, k)
    same = np.array([_end_key(t[:, elements[0, j]], bary[0, j]) == _end_key(t[:, elements[1, j]], bary[1, j])
                     for j in range(elements.shape[1])], dtype=bool)
    if np.all(same):
        raise ValueError(f"{field}.pairs: every pair ties a point to itself; nothing to tie")
    keep = ~same
    return {"elements": elements[:, keep], "barycentric": bary[:, keep], "stiffness": np.full(int(keep.sum()), k),
            "gaps": (at[0] - at[1])[:, keep], "tightness": np.zeros(int(keep.sum()))}


def _loose_elements(mesh, parent, stitch_elements, handles, material=None, every_piece_loose=None):
    """``(loose, pieces)``: which elements of ``mesh`` lie in pieces nothing holds, and how many pieces (0 when all
    or none are held; a piece held at a single node is not). ``parent`` maps its nodes to the mesh of the
    ``handles``, ``material`` tells the nodes with material at their place (:meth:`Handle.remap`);
    ``stitch_elements`` ``(2, k)``: the elements of the stitches' ends on ``mesh``. ``every_piece_loose``: the name
    of a change to refuse (``ParameterError`` naming ``handles``) when it leaves no piece held at two nodes."""
    t = mesh.t
    links = None if stitch_elements is None else t[0, stitch_elements]  # a stitch joins its ends' pieces
    _, labels = topology.connected_components(t, mesh.nvertices, links)
    places = [np.zeros((2, 0), dtype=np.int64)]  # (piece, old node) of every held node
    for h in handles:
        moved = h.remap(parent, material)
        if moved is not None:
            places.append(np.stack([labels[moved.nodes], np.asarray(parent)[moved.nodes]]))
    pinned = np.unique(np.hstack(places), axis=1)[0]
    # a piece held at one point only (a cut ending on the handle's node) turns freely about it: no equilibrium either
    held = np.bincount(pinned, minlength=labels.max() + 1) >= 2
    loose = ~held[labels[t[0]]]
    if every_piece_loose is not None and np.all(loose):
        raise ParameterError("handles", f"handles: {every_piece_loose} would leave no piece held at two nodes or more; "
                                        "a quasistatic body held at one point turns freely (no equilibrium)")
    if not np.any(loose) or np.all(loose):
        return np.zeros(t.shape[1], dtype=bool), 0
    return loose, int(np.unique(labels[t[0]][loose]).size)


def _material_after(edit, weights, regions):
    """The weights and regions of the elements of ``edit``'s mesh (a cut through elements brings its own)."""
    if isinstance(edit, element_cuts.ElementCut):
        weights, regions = edit.weights, edit.regions
    elif weights is None:
        return None, {}
    else:
        weights = weights[edit.elements]
        regions = {new: regions[old] for new, old in enumerate(edit.elements.tolist()) if old in regions}
    return (None if np.all(weights == 1.0) else weights), regions


def _snap(mesh, x, point):
    """The node nearest to ``point`` (positions ``x``); among coincident copies of a cut node, the one on the
    side of the point (whose elements' centroids are nearest)."""
    d = np.hypot(x[0] - point[0], x[1] - point[1])
    best = np.flatnonzero(d <= d.min() + 1e-12 * max(1.0, float(np.ptp(x))))
    if best.size == 1:
        return int(best[0])
    t = mesh.t
    centroids = x[:, t].mean(axis=1)
    scores = [np.hypot(*(centroids[:, np.any(t == node, axis=0)].mean(axis=1) - point)) for node in best]
    return int(best[int(np.argmin(scores))])


def _node_end(mesh, node):
    """A stitch end at ``node``: an element with that corner, and the corner's barycentric weights."""
    corner, element = np.nonzero(np.asarray(mesh.t) == node)
    if element.size == 0:
        raise ValueError(f"node {node} belongs to no element")
    w = np.zeros(np.shape(mesh.t)[0])  # a triangle's 3 corners, a tetrahedron's 4
    w[corner[0]] = 1.0
    return int(element[0]), w


def _point_end(mesh, x, point, weights, regions):
    """A stitch end at ``point`` (positions ``x``): on the material there or within half an element of it (in an
    open wound, just off its lip), or else at the nearest node."""
    found = element_cuts.locate(mesh, point, x, regions, reach=0.5)
    if found is not None:  # on a sliver of a cut element: carried by the firm tissue beside it
        return element_cuts.firm_anchor(mesh, *found, positions=x, weights=weights, regions=regions)
    return _node_end(mesh, _snap(mesh, x, point))


#: the operation of each method of an excision and an incision
_OPERATIONS = {"excisions": {"elements": element_cuts.excise_through, "edges": topology.excise},
               "incisions": {"elements": element_cuts.cut_through, "edges": topology.incise}}


def _end_key(nodes, weights):
    """A stitch end as ``{node: weight}`` (weights rounded), to tell two ends at the same point of the same nodes."""
    return {q: round(w, 9) for q, w in zip(nodes.tolist(), weights.tolist()) if w > 1e-12}
