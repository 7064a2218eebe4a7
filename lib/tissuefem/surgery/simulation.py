"""The running simulation: a scene built, stepped frame by frame, and operated on between frames.

:class:`Simulation` builds a :class:`~tissuefem.surgery.scene.Scene` (mesh, then excisions and
incisions, then the model of exactly the named terms, then the real-time solver) and offers the
virtual-surgery operations between frames: :meth:`~Simulation.grab`/:meth:`~Simulation.drag`/
:meth:`~Simulation.release`, :meth:`~Simulation.add_probe`, :meth:`~Simulation.cut`,
:meth:`~Simulation.excise` and :meth:`~Simulation.suture`. A topology change (cut, excision) builds
a new mesh and model and carries the state over (displacement, velocity, time, frame count);
nothing is lost.
"""

from __future__ import annotations

import contextlib
import copy
import dataclasses
import time

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components

from ..engine import meshes
from ..engine.contact import ContactSurface
from ..engine.model import Handle, Model, region_nodes
from ..engine.realtime import RealtimeSolver
from ..engine.terms import check_vector
from . import topology
from .scene import Scene, _number
from .surfaces import contact_surface

__all__ = ["Simulation"]


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

    def __init__(self, scene: Scene, *, clock=time.perf_counter, linear_solver=None, constant_tangent=True,
                 order: int = 1, intorder: int | None = None):
        if not isinstance(scene, Scene):
            raise ValueError(f"scene must be a Scene, got {scene!r}")
        self.scene = scene
        self.clock = clock
        self._linear_choice = linear_solver or scene.solver["linear_solver"]
        self._constant_tangent = bool(constant_tangent)
        self.order, self.intorder = order, intorder
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
        self._contact = self._contact_settings(scene, mesh)
        self._grab_count = 0
        # handles: resolved to nodes on the original mesh, then carried through the edits
        handles = []
        for i, h in enumerate(scene.effects.get("handles", [])):
            nodes = region_nodes(mesh, h["region"], f"effects.handles[{i}].region")
            handle = Handle(nodes, h["target"], name=h["name"])
            handle.nodes = nodes
            handles.append(handle)
        if not handles and not scene.dynamic:
            raise ValueError("effects.handles: a quasistatic scene needs at least one handle (e.g. a fixed edge), "
                             "or the body floats freely")
        self._pending_handles = handles  # until the first model takes them
        self._probe_specs = []
        self._probe_count = 0
        #: pieces lifted out because nothing held them (quasistatic scenes only; see _drop_loose_pieces)
        self.removed_pieces = 0
        self._sutures = None
        self._state = None
        if (scene.effects.get("excisions") or scene.effects.get("incisions")) and order != 1:
            raise ValueError("solver: excisions and incisions need P1 elements (order=1)")
        for i, e in enumerate(scene.effects.get("excisions", [])):
            self._apply_edit(topology.excise, np.asarray(e["polygon"], dtype=float), f"effects.excisions[{i}]",
                             rebuild=False)
        for i, e in enumerate(scene.effects.get("incisions", [])):
            self._apply_edit(topology.incise, np.asarray(e["path"], dtype=float), f"effects.incisions[{i}]",
                             rebuild=False)
        self._rebuild()
        for i, p in enumerate(scene.effects.get("probes", [])):
            self.add_probe(p["center"], p["radius"], p.get("stiffness"), _field=f"effects.probes[{i}]")
        for i, s in enumerate(scene.effects.get("sutures", [])):
            self.suture(s["pairs"], stiffness=s.get("stiffness"), tightness=s["tightness"],
                        _field=f"effects.sutures[{i}]")

    # ------------------------------------------------------------------ building
    @property
    def dynamic(self) -> bool:
        return self.scene.dynamic

    @property
    def handles(self) -> dict:
        """The handles holding the tissue, by name (the model owns them)."""
        source = self.model.handles if hasattr(self, "model") else self._pending_handles
        return {h.name: h for h in source}

    def _current_handles(self) -> list:
        return list(self.model.handles) if hasattr(self, "model") else list(self._pending_handles)

    def _build_model(self, handles) -> Model:
        """The model of exactly the scene's effects on the current mesh, holding ``handles``."""
        effects = self.scene.effects
        inertia = effects.get("inertia")
        gravity = effects.get("gravity")
        tractions = [(t["boundary"], t["traction"]) for t in effects.get("tractions", [])]
        probes = [dict(center=p["center"], radius=p["radius"], stiffness=p["stiffness"], label=p["label"])
                  for p in self._probe_specs]
        try:
            return Model(
                self.mesh, self.material, order=self.order, intorder=self.intorder, handles=handles,
                dt=None if inertia is None else inertia["time_step"], density=self.density,
                mass="lumped" if inertia is None else inertia["mass"],
                gravity=None if gravity is None else gravity["acceleration"],
                tractions=tractions or None, fibers=self._fibers, probes=probes, sutures=self._sutures,
                contact=self._contact_spec(),
            )
        except ValueError as err:
            if "tractions" in str(err) and "effects." not in str(err):
                raise ValueError(f"effects.tractions: {err}") from None
            if str(err).startswith("contact."):
                raise ValueError(f"effects.{err}") from None
            raise

    #: the default depth of the contact skin, in the median length of the surface's segments (its boundary
    #: edges), and its stiffness (a pressure), in Young's moduli
    CONTACT_DISTANCE, CONTACT_STIFFNESS = 0.25, 1.0

    @classmethod
    def _contact_settings(cls, scene, mesh):
        """The scene's contact effect with its defaults filled in (fixed for the whole run, so the skin does not
        change when a cut rebuilds the model), or ``None``."""
        spec = scene.effects.get("contact")
        if spec is None:
            return None
        if "distance" in spec:
            distance = spec["distance"]
        else:
            surface = ContactSurface.from_mesh(mesh)
            ends = surface.segment_positions(mesh.p)
            distance = cls.CONTACT_DISTANCE * float(np.median(np.hypot(*(ends[:, 1] - ends[:, 0]).T)))
        return {"distance": distance,
                "stiffness": spec.get("stiffness", cls.CONTACT_STIFFNESS * scene.material["youngs_modulus"])}

    def _contact_spec(self):
        """The model's ``contact`` argument: the surface of the current mesh and the run's settings. (A body cut
        through elements passes its weights and regions: ``contact_surface(mesh, weights, regions)``.)"""
        if self._contact is None:
            return None
        return dict(self._contact, surface=contact_surface(self.mesh))

    def _rebuild(self, handles=None):
        """Build the model and the solver for the current mesh, keeping the state (if any)."""
        handles = self._current_handles() if handles is None else handles
        model = self._build_model(handles)
        solver_settings = self.scene.solver
        choice = self._linear_choice
        if model.quadratic and self._constant_tangent and isinstance(choice, str):
            # a constant Hessian: one factorization per held set is exact (with the named direct backend)
            base = choice[len("reuse-"):] if choice.startswith("reuse-") else choice
            choice = "constant" if base in ("reuse", "direct", "background", "superlu") else f"constant-{base}"
        solver = RealtimeSolver(model, linear_solver=choice, budget=solver_settings["budget"],
                                rtol=solver_settings["rtol"], clock=self.clock,
                                max_iterations=solver_settings["max_iterations"])
        previous = getattr(self, "solver", None)
        if self._state is not None:
            u, v, v_prev, t, frames, budget, dt = self._state
            solver.set_state(u, v if model.dynamic else None, v_previous=v_prev if model.dynamic else None,
                             time_=t, steps=frames)
            solver.budget = budget
            if dt is not None:
                solver.dt = dt
            solver.last_report = previous.last_report if previous is not None else None
        self.model, self.solver = model, solver
        self._state = None

    @contextlib.contextmanager
    def _transaction(self):
        """Apply a change completely or not at all: on any error, everything is put back as it was."""
        saved = (self.mesh, self._fibers, copy.deepcopy(self._sutures), copy.deepcopy(self._probe_specs),
                 getattr(self, "model", None), getattr(self, "solver", None), self._grab_count, self._probe_count,
                 self.removed_pieces)
        handles = [(h, h.target) for h in self._current_handles()]
        try:
            yield
        except BaseException:
            (self.mesh, self._fibers, self._sutures, self._probe_specs, model, solver, self._grab_count,
             self._probe_count, self.removed_pieces) = saved
            self._state = None
            if model is not None:
                self.model, self.solver = model, solver
                model.handles[:] = [h for h, _ in handles]
                for h, target in handles:
                    h.target = target
            raise

    def _check_held(self, handles):
        """A quasistatic scene must keep at least one handle (or the body floats and K is singular)."""
        if not self.dynamic and not handles:
            raise ValueError("handles: a quasistatic scene needs at least one handle; this change would leave none")

    def _save_state(self):
        s = self.solver
        self._state = (s.u.copy(), s.v.copy(), None if s.v_previous is None else s.v_previous.copy(),
                       s.time, s.steps, s.budget, s.dt)

    # ------------------------------------------------------------------ frames
    @property
    def terms(self) -> list[str]:
        """The terms the model evaluates (inertia, elastic, fibres, probes, sutures, loads), with the
        inversion handling wrapped around the elastic term named after it."""
        names = self.model.term_names
        if "inversion" in self.scene.effects:  # the elastic term's material is wrapped, not a term of its own
            i = names.index("elastic") + 1
            names = names[:i] + [f"inversion ({self.scene.effects['inversion']['method']})"] + names[i:]
        return names

    @property
    def u(self):
        return self.solver.u

    @property
    def v(self):
        return self.solver.v

    @property
    def frames(self) -> int:
        return self.solver.steps

    @property
    def time(self) -> float:
        return self.solver.time

    def frame(self, targets=None):
        """One frame. ``targets``: ``{handle name: translation (dx, dy) or map}`` (others keep theirs)."""
        if targets and not isinstance(targets, dict):
            raise ValueError(f"targets must be a dict {{handle name: target}}, got {targets!r}")
        return self.solver.frame(targets or None)

    def run(self, frames: int, targets=None):
        """Run ``frames`` frames (with the same ``targets`` for each); return the reports."""
        return [self.frame(targets) for _ in range(int(frames))]

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
        """Grab the nodes within ``radius`` of ``point`` (deformed coordinates); returns the handle's name.

        The grabbed nodes stay where they are until :meth:`drag` moves them (by
        the mouse's offset from the grab point). Default radius: 1.5 mean edge lengths.
        """
        radius = 1.5 * meshes.mean_edge_length(self.mesh) if radius is None else _number("radius", radius, positive=True)
        point = check_vector("point", point)
        if self.order != 1:
            raise ValueError("grab: grabbing needs P1 elements (order=1)")
        x = self.positions()
        d = np.hypot(x[0] - point[0], x[1] - point[1])
        nodes = np.flatnonzero(d <= radius)
        if nodes.size == 0:
            raise ValueError(f"point {point.tolist()}: no tissue within radius {radius:g}")
        names = set(self.handles)
        count = self._grab_count + 1
        while f"grab{count}" in names:  # never replace a scene's handle of the same name
            count += 1
        u = self.solver.u.reshape(-1, 2).T
        self.model.add_handle(Handle(nodes, base=u[:, nodes].copy(), name=f"grab{count}", anchor=point))
        self._grab_count = count
        return f"grab{count}"

    def drag(self, name, point) -> None:
        """Move a grabbed handle so that its grab point follows ``point``."""
        h = self.model.handle(name)
        point = check_vector("point", point)
        self.model.handle(name).move(point - (np.zeros(2) if h.anchor is None else h.anchor))

    def handle_offset(self, name) -> np.ndarray:
        t = self.model.handle(name).target
        return None if callable(t) else t.copy()

    def move_handle(self, name, target) -> None:
        """Set a handle's target (a translation or a map), checked; takes effect at the next frame."""
        self.model.handle(name).move(target)

    def release(self, name) -> None:
        """Let go of a handle: its nodes are free from the next frame on."""
        handle = self.model.handle(name)
        self._check_held([h for h in self.model.handles if h is not handle])
        self.model.remove_handle(name)

    # ------------------------------------------------------------------ probe
    def add_probe(self, center, radius, stiffness=None, _field="probe"):
        """Press a rigid disc (a tool tip) into the tissue; returns its label for :meth:`move_probe`."""
        center = check_vector(f"{_field}.center", center).tolist()
        radius = _number(f"{_field}.radius", radius, positive=True)
        E = self.scene.material["youngs_modulus"]
        if stiffness is None:  # stiff enough to keep the penetration near 1 % of the radius under moderate pressure
            with np.errstate(over="ignore"):
                stiffness = _number(f"{_field}.stiffness (default 100 E / radius)", 100.0 * E / radius)
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
            if operation is topology.incise:  # cut where the user drew, on the deformed tissue
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
            new_handles = [m for m in (h.remap(parent) for h in self._current_handles()) if m is not None]
            self._check_held(new_handles)
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
                self._rebuild(new_handles)
            else:
                self._pending_handles = new_handles
        return edit

    def _drop_loose_pieces(self, edit):
        """Quasistatic scenes: remove pieces that nothing holds (no handle, no suture to a held piece).

        Such a piece has no equilibrium (its stiffness matrix is singular, and
        under a load it would run away), so it is lifted out of the simulation,
        as a surgeon lifts out what was cut free. Dynamic scenes keep every piece.
        """
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
        for h in self._current_handles():
            moved = h.remap(edit.parent)
            if moved is not None:
                held[labels[moved.nodes]] = True
        loose = ~held[labels[t[0]]]
        if not np.any(loose) or np.all(loose):
            return edit  # nothing to drop (or nothing held at all: _check_held reports it)
        second = topology.excise(mesh, lambda centroids: loose)
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
        velocity. Returns the :class:`tissuefem.surgery.topology.MeshEdit`.
        """
        return self._apply_edit(topology.incise, _polyline(polyline), "polyline")

    def excise(self, region):
        """Remove the elements inside ``region`` (a polygon in *reference* coordinates, or a mask on centroids)."""
        if not callable(region):
            region = _polyline(region, minimum=3, field="region")
        return self._apply_edit(topology.excise, region, "region")

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

