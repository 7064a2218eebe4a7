"""The self-contact term: the barrier on the signed gaps of the pairs in contact, and the hooks it needs."""

import numpy as np

from ..meshes import MeshMap
from ..parameters import (CONTACT_STIFFNESS_MAX, YOUNGS_MODULUS_RANGE, ParameterError, check_real,
                          check_real_array)
from ..terms import Term
from .barrier import barrier, gap_derivatives
from .candidates import CandidatePairs, find_keys
from .collision import crossings, step_fraction
from .surface import ContactSurface, segment_distance


class Contact(Term):
    """Self-contact of a :class:`ContactSurface` at the reference node positions ``X`` (2, n_nodes): a one-sided
    barrier in the skin behind it. ``distance``: ``d^``, the skin's depth (the largest overlap), at most half the
    median segment length; ``stiffness``: ``kappa``, a pressure (at most 1e16; a model allows 1e4 Young's moduli);
    ``skin``: the Verlet list's margin (default: the median segment length). ``pairs``: the
    :class:`~.candidates.CandidatePairs`; ``offset``: the rest offsets."""

    name = "contact"
    has_safe_hessian = True

    def __init__(self, X, surface, distance, stiffness, skin=None):
        if not isinstance(surface, ContactSurface):
            raise ParameterError("contact.surface",
                                 f"contact.surface must be a ContactSurface, got {type(surface).__name__}")
        X = check_real_array("X", X)
        if X.ndim != 2 or X.shape[0] != 2 or not np.all(np.isfinite(X)):
            raise ParameterError("X", f"X must be finite node positions shaped (2, n_nodes), got shape {X.shape}")
        if X.shape[1] != surface.n_nodes:
            raise ParameterError("contact.surface", f"contact.surface combines {surface.n_nodes} nodes but the mesh "
                                                    f"has {X.shape[1]}")
        self.X, self.n_nodes, self.surface = X, X.shape[1], surface
        self.distance = check_real("contact.distance", distance, 0.0, lo_open=True)
        # (against the material's Young's modulus where the model is built: parameters.check_contact_stiffness)
        stiffest = CONTACT_STIFFNESS_MAX * YOUNGS_MODULUS_RANGE[1]
        self.stiffness = check_real("contact.stiffness", stiffness, 0.0, stiffest, lo_open=True)
        Y, (a, b) = surface.positions(X), surface.segments
        self.rest_length = np.hypot(*(Y[:, b] - Y[:, a]))
        if np.any(self.rest_length <= 1e-12 * max(1.0, float(np.ptp(X)))):
            raise ParameterError("contact.surface",
                                 f"contact.surface: segment {int(np.argmin(self.rest_length))} has zero length")
        self.point_length = 0.5 * (np.bincount(a, self.rest_length, minlength=surface.n_points)
                                   + np.bincount(b, self.rest_length, minlength=surface.n_points))
        median = float(np.median(self.rest_length)) if self.rest_length.size else np.inf
        if self.distance > 0.5 * median:
            raise ParameterError("contact.distance", f"contact.distance = {self.distance:g} must be at most half the "
                                 f"surface's median segment length ({0.5 * median:g}): the skin is a thin layer")
        self._skin_setting = skin
        self.skin = (median if np.isfinite(median) else 1.0) if skin is None else \
            check_real("contact.skin", skin, 0.0, lo_open=True)
        # local dofs of a (point, a, b) triple: (point j, node slot k, component c) -> 6-vector entry 2 j + c
        j, k, c = np.meshgrid(np.arange(3), np.arange(surface.nodes.shape[1]), np.arange(2), indexing="ij")
        self._slots, self._slot_local = (j.ravel(), k.ravel(), c.ravel()), (2 * j + c).ravel()
        self.pairs = CandidatePairs(surface, Y, self.rest_length, self.distance, self.skin)
        self.offset = self.pairs.offset
        self._through = (np.zeros(0, dtype=np.intp), np.zeros(0, dtype=np.intp))  # pairs a handle dragged through
        self._cache = self._seen = self.pattern = None
        self._coupled = self._covered = np.zeros(0, dtype=np.int64)

    def remap(self, meshmap) -> "Contact":
        """This contact (same settings) on the new mesh of a :class:`~tissuefem.engine.meshes.MeshMap`, on the
        surface the change knows (``meshmap.contact_surface()``), else on the new mesh's boundary."""
        if not isinstance(meshmap, MeshMap):
            raise ParameterError("meshmap", f"meshmap must be a MeshMap, got {type(meshmap).__name__}")
        surface = meshmap.contact_surface() or ContactSurface.from_mesh(meshmap.mesh)
        return Contact(meshmap.mesh.p, surface, self.distance, self.stiffness, self._skin_setting)

    def describe(self):
        return f"contact: {self.surface.n_segments} segments, d^ = {self.distance:g}, kappa = {self.stiffness:g}"

    def _points(self, u, name="u") -> np.ndarray:
        u = np.asarray(u)
        if u.ndim != 1 or u.size < 2 * self.n_nodes or u.dtype.kind not in "iuf":
            u = check_real_array(name, u)  # names what is not a real array
            raise ParameterError(name, f"{name} must be a displacement vector of at least {2 * self.n_nodes} real "
                                       f"numbers, got shape {u.shape}")
        return self.surface.positions(self.X + u[: 2 * self.n_nodes].reshape(-1, 2).T)

    def _evaluate(self, u):
        """The active pairs at ``u``, cached by the points: their point ``p``, segment ``s``, ``keys``, ``rows`` (in
        ``pairs.positions``), ``kind`` and gap ``sigma`` (:meth:`~.candidates.CandidatePairs.classify`)."""
        Y = self._points(u)
        pairs = self.pairs
        if self._cache is not None and self._cache["list"] == pairs.refreshes and np.array_equal(self._cache["Y"], Y):
            return self._cache
        pairs.ensure(Y)
        p, s, keys, ignored, rows = pairs.current(Y)
        active = np.zeros(0, dtype=np.intp)
        kind = sigma = np.zeros(0)
        if p.size:
            seg = self.surface.segments
            # only the pairs within d^ take part (the runs, the owners): find them first, cheaply
            near = np.flatnonzero(segment_distance(Y[:, p], Y[:, seg[0, s]], Y[:, seg[1, s]]) < pairs.skins[p])
            p, s, keys, ignored, rows = p[near], s[near], keys[near], ignored[near], rows[near]
            if p.size:
                kind, distance, sigma = pairs.classify(lambda i: Y[:, i], p, s)
                near = np.flatnonzero(distance < pairs.skins[p])
                near = near[pairs.owners(p[near], s[near], keys[near], distance[near])]
                active = near[(sigma[near] < -self.offset[p[near]]) & ~ignored[near]]
        self._cache = {"Y": Y, "list": pairs.refreshes, "p": p[active], "s": s[active], "keys": keys[active],
                       "rows": rows[active], "kind": kind[active].astype(int), "sigma": sigma[active].astype(float)}
        self._seen = Y
        return self._cache

    def _local(self, c):
        """``(grad (m, 6), hess (m, 6, 6), dofs, weights (m, 6 k))`` of the active pairs, once per cached state: the
        derivatives of each gap by its points ``(p, a, b)``, and the node dofs of those 6 coordinates with weights."""
        if "local" not in c:
            seg = self.surface.segments
            p, a, b = c["p"], seg[0, c["s"]], seg[1, c["s"]]
            points = np.stack([p, a, b], axis=1)
            nodes, weights = self.surface.nodes[points], self.surface.weights[points]  # (m, 3, k)
            j, k, comp = self._slots
            c["local"] = (*gap_derivatives(c["Y"], p, a, b, c["kind"]), 2 * nodes[:, j, k] + comp, weights[:, j, k])
        return c["local"]

    def _barrier(self, c):
        """``(l kappa d^ beta, l kappa beta', l kappa beta'' / d^)`` of the active pairs: the energy and its first two
        derivatives by ``sigma``."""
        d = self.distance
        b0, b1, b2 = barrier(1.0 + (c["sigma"] + self.offset[c["p"]]) / d)
        scale = self.stiffness * self.point_length[c["p"]]
        return scale * d * b0, scale * b1, scale * b2 / d

    def energy(self, u) -> float:
        c = self._evaluate(u)
        return float(np.sum(self._barrier(c)[0])) if c["p"].size else 0.0

    def gradient(self, u) -> np.ndarray:
        out = np.zeros(np.asarray(u).size)
        c = self._evaluate(u)
        if c["p"].size:
            grad, _, dofs, coef = self._local(c)
            values = coef * (self._barrier(c)[1][:, None] * grad)[:, self._slot_local]
            out[: 2 * self.n_nodes] += np.bincount(dofs.ravel(), weights=values.ravel(), minlength=2 * self.n_nodes)
        return out

    def add_hessian(self, u, data, safe=False) -> None:
        c = self._evaluate(u)
        if c["p"].size == 0:
            return
        grad, hess, dofs, coef = self._local(c)
        _, e1, e2 = self._barrier(c)
        H = e2[:, None, None] * grad[:, :, None] * grad[:, None, :]
        if not safe:
            H = H + e1[:, None, None] * hess
        local = self._slot_local
        block = coef[:, :, None] * coef[:, None, :] * H[:, local[:, None], local[None, :]]
        # the positions of each pair's (6 k)^2 entries in the pattern's data, looked up once per pattern
        pos = self.pairs.positions[c["rows"]]
        missing = pos[:, 0] < 0
        if np.any(missing):
            d = dofs[missing]
            pos[missing] = self.pattern.positions(np.repeat(d, d.shape[1], axis=1).ravel(),
                                                  np.tile(d, (1, d.shape[1])).ravel()).reshape(d.shape[0], -1)
            self.pairs.positions[c["rows"][missing]] = pos[missing]
        np.add.at(data, pos.ravel(), block.ravel())

    def couplings(self):
        """The dof couplings of the pairs the contact may need now: the list, and the hinges sharp where the surface
        was last seen (the model asks when :meth:`covers` says the pattern lacks one)."""
        p, s, keys, _, _ = self.pairs.current(self._seen if self._seen is not None else self.pairs.points)
        self._coupled = np.sort(keys)
        if p.size == 0:
            return None
        seg = self.surface.segments
        points = np.stack([p, seg[0, s], seg[1, s]], axis=1)
        nodes = np.unique(np.sort(self.surface.nodes[points].reshape(points.shape[0], -1), axis=1), axis=0)
        rows, cols = np.repeat(nodes, nodes.shape[1], axis=1).ravel(), np.tile(nodes, (1, nodes.shape[1])).ravel()
        r, q = np.divmod(np.unique(rows.astype(np.int64) * self.n_nodes + cols), self.n_nodes)
        return (np.concatenate([2 * r, 2 * r, 2 * r + 1, 2 * r + 1]),
                np.concatenate([2 * q, 2 * q + 1, 2 * q, 2 * q + 1]))

    def bind(self, pattern) -> None:
        super().bind(pattern)
        self._covered = self._coupled
        self.pairs.positions[:] = -1

    def covers(self, u) -> bool:
        """Whether the bound pattern holds the couplings of every pair active at ``u`` (else the model rebuilds it)."""
        return bool(np.all(find_keys(self._covered, self._evaluate(u)["keys"]) >= 0))

    def begin_step(self, u, previous=None) -> int:
        """Start a step at ``u``; returns how many points the handles' motion from ``previous`` carried through a
        wall and that stay behind it (less than the segment's length deep: farther, a gap's sign says nothing)."""
        Y = self._points(u)
        self.pairs.start_step(Y)
        through_p, through_s = self._through
        if previous is not None:
            p, s = crossings(self.pairs, self._points(previous, "previous"), Y)
            through_p, through_s = np.concatenate([through_p, p]), np.concatenate([through_s, s])
        if through_p.size:
            _, _, sigma = self.pairs.classify(lambda i: Y[:, i], through_p, through_s)
            deep = (sigma <= -self.pairs.skins[through_p]) & (sigma > -self.rest_length[through_s])
            through_p, through_s = np.unique(np.stack([through_p[deep], through_s[deep]]), axis=1)
        self._through = (through_p.astype(np.intp), through_s.astype(np.intp))
        return int(np.unique(self._through[0]).size)

    def end_step(self) -> None:
        """Forget the step's start (every pair counts again)."""
        self.pairs.end_step()
        self._cache = None

    def max_step(self, u, du) -> float:
        """The largest fraction of the step ``u -> u + du`` free of crossings (:func:`~.collision.step_fraction`)."""
        Y0 = self._points(u)
        du = np.asarray(du)
        if du.shape != np.shape(u):
            raise ParameterError("du", f"du must be shaped like u {np.shape(u)}, got {du.shape}")
        return step_fraction(self.pairs, Y0, self._points(np.asarray(u) + du, "du") - Y0)

    def active_pairs(self, u) -> np.ndarray:
        """The (point, segment) pairs in contact at ``u``: shape (2, m)."""
        c = self._evaluate(u)
        return np.stack([c["p"], c["s"]])

    def overlap(self, u) -> float:
        """The deepest any point is pressed into its skin at ``u`` beyond its rest offset (0: nothing touches)."""
        c = self._evaluate(u)
        return float(-(c["sigma"] + self.offset[c["p"]]).min()) if c["p"].size else 0.0
