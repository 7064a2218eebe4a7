"""The terms of the potential: each effect a scene can name is one term with one interface.

The whole engine minimises one energy (the *incremental potential*; see :mod:`tissuefem.engine.stepping`). A
:class:`~tissuefem.engine.model.Model` is the sum of exactly the terms it was built with:

=====================  ===========================================================  ==========
term                   energy                                                       Hessian
=====================  ===========================================================  ==========
:class:`Elastic`       ``sum_e A_e Psi(F_e)``, the material's stored energy         assembled
:class:`Fibers`        ``sum_e A_e k/8 (|F_e g_e|^2 - 1)^2`` (chapter 5)             assembled
:class:`Inertia`       ``1/(2 dt^2) (x - x~)^T M (x - x~)``, backward Euler          constant
:class:`Load`          ``-f . u``: gravity, a body force, tractions                  zero
:class:`Probe`         a rigid disc (a ball in 3D) pressed into the tissue           per node
:class:`Sutures`       zero-length springs tying pairs of points                     constant
:class:`GhostPenalty`  jumps of ``grad u`` at the pieces of elements cut through    constant
``Contact``            self-contact of the surface, see :mod:`.contact`             per pair
=====================  ===========================================================  ==========

Inertia carries ``1/dt^2`` so that the gradient of ``W(u) - f.u + Inertia(u)`` is exactly the notes' residual
``q = M (u - u~)/dt^2 + f_int(u) - f_ext`` (with the README's errata): a force, as in a quasistatic step. The
chapters' ``E = 1/2 |u - u~|_M^2 + dt^2 [W - f.u]`` is this potential times ``dt^2``: the same minimiser.

Every term reads the dimension from the mesh (triangles or tetrahedra: one code path); only self-contact and the
ghost penalty of cuts are 2D only for now, and refuse a tetrahedron mesh by name (:func:`refuse_3d`).
"""

from __future__ import annotations

import numbers

import numpy as np
import scipy.sparse as sp
from skfem import FacetBasis, LinearForm, asm

from .assembly import element_geometry
from .materials import FiberFamily, check_fiber_stiffness, vector_length
from .parameters import (FORCE_MAX, REACH, YOUNGS_MODULUS_RANGE, ParameterError, check_bounded_vector, check_density,
                         check_indices, check_penalty_stiffness, check_radius, check_reach, check_real,
                         check_real_array, check_time_step, check_vector, check_weights, string)
from .vectors import dot

__all__ = ["Term", "ElementTerm", "ConstantHessian", "Elastic", "GhostPenalty", "GHOST_WEIGHT", "GHOST_PENALTY",
           "Fibers", "Inertia", "Load", "Probe", "Sutures", "traction_vector", "SummedDensity", "extent", "refuse_3d",
           "boundary_lengths", "surface_lengths", "node_blocks"]


class Term:
    """One additive piece of the potential: ``energy(u)``, ``gradient(u)`` (a dof vector) and
    ``add_hessian(u, data)``, which adds the Hessian into ``data``, the CSR data of the model's one sparsity
    pattern (given by ``bind``). ``couplings()``: Hessian entries the mesh's pattern lacks (sutures).

    Hooks with do-nothing defaults, which the model calls only on the terms that override them (so a model
    without one pays nothing per iteration): ``covers(u)`` (does the pattern still hold the couplings?
    self-contact's pairs change), ``max_step(u, du)`` (the largest fraction of ``du`` allowed),
    ``begin_step(u, previous)`` (returns the crossings found) with ``end_step()``. ``remap(meshmap)``: the term
    after a topology change, ``None`` if nothing survives, or a factory ``model -> Term``.
    """

    name = "term"
    quadratic = False  #: a constant Hessian (then a kept factorization is exact)
    has_safe_hessian = False  #: whether ``add_hessian(..., safe=True)`` differs from the exact Hessian
    #: the term's place in the model's sums (inertia, element terms, probes, sutures, others, loads): a term
    #: added to a running model sums as if the model had been built with it
    rank = 5

    def bind(self, pattern) -> None:
        self.pattern = pattern

    def couplings(self):
        return None

    def energy(self, u) -> float:
        raise NotImplementedError

    def gradient(self, u) -> np.ndarray:
        raise NotImplementedError

    def add_hessian(self, u, data, safe=False) -> None:
        """``safe=True`` asks for a positive semi-definite version (where ``has_safe_hessian``)."""
        raise NotImplementedError

    def covers(self, u) -> bool:
        return True

    def max_step(self, u, du) -> float:
        return 1.0

    def begin_step(self, u, previous=None) -> int:
        return 0

    def end_step(self) -> None:
        pass

    def remap(self, meshmap):
        raise NotImplementedError(f"{self.name}: this term cannot be carried across a topology change")

    def describe(self) -> str:
        return self.name

    def __repr__(self):
        return f"<{self.describe()}>"


class ElementTerm(Term):
    """A term ``sum_e int Psi(F) dX`` of an energy density ``density`` (energy/stress/tangent of ``F``); the model
    sums the densities of all element terms in one assembly pass (:class:`SummedDensity`)."""

    density = None
    rank = 1

    def __init__(self, assembler):
        self.assembler = assembler

    def energy(self, u):
        return self.assembler.energy(u, self.density)

    def gradient(self, u):
        return self.assembler.residual(u, self.density)

    def add_hessian(self, u, data, safe=False):
        density = SummedDensity([self.density], safe=True) if safe else self.density
        self.pattern.add_base(data, self.assembler.tangent(u, density).data)


class Elastic(ElementTerm):
    """The material's stored energy ``W(u) = sum_e A_e Psi(F_e)``."""

    name = "elastic"

    def __init__(self, assembler, material):
        super().__init__(assembler)
        for what in ("energy", "stress", "tangent"):
            if not callable(getattr(material, what, None)):
                raise ValueError(f"material must have energy, stress and tangent methods, got {material!r}")
        self.material = self.density = material
        self.quadratic = getattr(material, "name", "") == "linear"

    def describe(self):
        return f"elastic: {getattr(self.material, 'name', type(self.material).__name__)}"


class ConstantHessian(Term):
    """A quadratic term whose Hessian is the constant entries ``entries() -> (rows, cols, values)``, which may
    couple dofs the mesh does not (sutures: the model widens its pattern)."""

    quadratic = True

    def entries(self):
        raise NotImplementedError

    def couplings(self):
        return self.entries()[:2]

    def bind(self, pattern):
        super().bind(pattern)
        rows, cols, self._values = self.entries()
        self._positions = pattern.positions(rows, cols)

    def add_hessian(self, u, data, safe=False):
        np.add.at(data, self._positions, self._values)


#: The pieces of triangles cut through that get a ghost penalty (:class:`GhostPenalty`): those lighter than this share
#: of their triangle (1: every piece, as Burman's penalty acts on every face of a cut element)
GHOST_WEIGHT = 1.0
#: The ghost penalty's factor ``gamma``, times the material's shear modulus at rest
GHOST_PENALTY = 0.1


class GhostPenalty(ConstantHessian):
    """The ghost penalty of a mesh cut through its elements: ``E = 1/2 sum_(e, f) c_ef |grad u_e - grad u_f|^2`` over
    the pairs of a piece ``e`` (weight below ``light``) and an element ``f`` sharing an edge (both its nodes) with it,
    not a copy of the same triangle; ``c_ef = gamma mu (A_e + A_f)`` (the whole triangles' areas).

    A piece of a triangle holds its virtual nodes with a stiffness proportional to its weight, but a load on its lip (a
    stitch, a grab, contact) reaches them with the lip point's barycentric coefficients: a thin piece's virtual nodes
    move far more than the real nodes round them, the spikes at crack tips and the crumpling lips. The penalty ties
    each piece's deformation gradient to its neighbour's across their shared edge, as the ghost penalty of Burman [1]_
    does across the faces of cut elements (Hansbo and Hansbo [2]_ for the cut element method; the virtual nodes of
    Molino, Bao and Fedkiw: :mod:`tissuefem.surgery.element_cuts`). It is zero for every linear displacement field
    (the patch test holds) and every rigid motion (``grad u = R - I`` in both elements), vanishes as the mesh is
    refined (a smooth field's gradient jumps by ``O(h)``), and is absent where no element is cut. ``mesh``: the cut
    mesh (P1); ``weights``: its elements' weights; ``modulus``: ``mu`` (a pressure); ``pairs`` (2, m): the element
    pairs tied; ``K``: the constant Hessian.

    .. [1] E. Burman, *Ghost penalty*, Comptes Rendus Mathematique 348(21-22) (2010), 1217-1220.
    .. [2] A. Hansbo, P. Hansbo, *A finite element method for the simulation of strong and weak discontinuities in
       solid mechanics*, Computer Methods in Applied Mechanics and Engineering 193 (2004), 3523-3540.
    """

    name = "ghost penalty"
    rank = 4  # after the element terms and the tools (probes, sutures), before the others

    def __init__(self, mesh, weights, modulus, gamma=GHOST_PENALTY, light=GHOST_WEIGHT):
        refuse_3d("ghost penalty", mesh.p)  # cuts through elements are 2D only for now
        self.gamma = check_real("ghost_penalty.gamma", gamma, 0.0)
        self.modulus = check_real("ghost_penalty.modulus", modulus, 0.0, YOUNGS_MODULUS_RANGE[1])
        light = check_real("ghost_penalty.light", light, 0.0, 1.0)
        p, t = np.asarray(mesh.p, dtype=float), np.asarray(mesh.t, dtype=np.intp)
        self.n_nodes, m = p.shape[1], t.shape[1]
        w = check_weights(weights, m)
        centre = p[:, t].mean(axis=1)
        t, _, area, G = element_geometry(p, t)  # of the whole triangles: a piece keeps its shape functions
        # the elements on each edge (its two nodes): those sharing an edge with a light one
        keys = np.sort(np.stack([t, np.roll(t, -1, axis=0)]), axis=0)
        keys = (keys[0] * self.n_nodes + keys[1]).ravel()  # (3 m,): local edge k of element e at k * m + e
        order = np.argsort(keys, kind="stable")
        sorted_keys, owner = keys[order], order % m
        found = set()
        for e in np.flatnonzero(w < light).tolist():
            for k in keys[[e, m + e, 2 * m + e]].tolist():
                lo, hi = np.searchsorted(sorted_keys, k), np.searchsorted(sorted_keys, k, side="right")
                for f in owner[lo:hi].tolist():
                    if f != e and not np.allclose(centre[:, f], centre[:, e], rtol=0.0, atol=1e-12 * np.sqrt(area[e])):
                        found.add((min(e, f), max(e, f)))  # (a copy of the same triangle lies across the cut)
        self.pairs = np.array(sorted(found), dtype=np.intp).reshape(-1, 2).T
        e, f = self.pairs
        nodes = np.concatenate([t[:, e], t[:, f]])  # (6, n_pairs): e's nodes, then f's
        g = np.concatenate([G[:, :, e], -G[:, :, f]])  # (6, 2, n_pairs): grad u_e - grad u_f = sum_a u_a g_a^T
        block = (self.gamma * self.modulus * (area[e] + area[f])) * np.einsum("ajp,bjp->abp", g, g)  # (6, 6, n_pairs)
        self._rows, self._cols, self._values = node_blocks(nodes, block, 2)
        n = 2 * self.n_nodes
        self.K = sp.csr_matrix((self._values, (self._rows, self._cols)), shape=(n, n))

    @classmethod
    def of(cls, mesh, weights, material) -> "GhostPenalty | None":
        """The ghost penalty of a cut ``mesh`` with ``weights`` and ``material`` (its shear modulus at rest: the
        tangent's ``A_0101`` at ``F = I``), or ``None`` where no element is light."""
        if weights is None or not np.any(np.asarray(weights) < GHOST_WEIGHT):
            return None
        A = np.asarray(material.tangent(np.eye(2)[:, :, None]), dtype=float)
        ghost = cls(mesh, weights, float(A.reshape(2, 2, 2, 2, -1)[0, 1, 0, 1].mean()))
        return ghost if ghost.pairs.shape[1] else None

    def energy(self, u):
        v = np.asarray(u)[: 2 * self.n_nodes]
        return 0.5 * float(v @ (self.K @ v))

    def gradient(self, u):
        g = np.zeros(np.asarray(u).size)
        g[: 2 * self.n_nodes] = self.K @ np.asarray(u)[: 2 * self.n_nodes]
        return g

    def entries(self):
        return self._rows, self._cols, self._values

    def remap(self, meshmap):
        return None  # the new model makes its own from its weights

    def describe(self):
        return f"ghost penalty: {self.pairs.shape[1]} pairs of elements, gamma = {self.gamma:g}"


class Fibers(ElementTerm):
    """The fibre energy ``k/8 (I4 - 1)^2``, ``I4 = |F g|^2`` (chapter 5), on any material: ``k >= 0`` is the
    extra small-strain modulus along ``directions``, ``(d,)`` or ``(d, n_elements)`` (normalised here), ``d`` the
    mesh's dimension (2: triangles, 3: tetrahedra)."""

    name = "fibers"

    def __init__(self, assembler, stiffness, directions):
        super().__init__(assembler)
        self.stiffness = check_fiber_stiffness(stiffness, "fibers.stiffness")
        nel, d = assembler.n_elements, getattr(assembler, "dim", 2)
        g = check_real_array(f"fibers.direction (an array of {d}D vectors)", directions)  # complex is refused, not cut
        if g.ndim == 1 and g.shape == (d,):
            g = np.repeat(g.reshape(d, 1), nel, axis=1)
        if g.shape != (d, nel):
            raise ValueError(f"fibers.direction must be shaped ({d},) or ({d}, n_elements={nel}), got {g.shape}")
        self.given = g  # as given (a remap carries these, so the normalisation is done once, as at the start)
        self.density = FiberFamily(self.stiffness, g)
        self.directions = self.density.fibers

    def remap(self, meshmap):
        return lambda model: Fibers(model.assembler, self.stiffness, meshmap.transfer_elements(self.given))

    def describe(self):
        return f"fibers: k = {self.stiffness:g}"


class SummedDensity:
    """The sum of energy densities evaluated on one ``F`` (one assembly pass for all element terms); with
    ``safe``, each density's positive semi-definite ``safe_tangent`` where it offers one (the safe Hessian)."""

    def __init__(self, densities, safe=False):
        self.densities, self.safe = list(densities), safe
        self.name = " + ".join(getattr(d, "name", "?") for d in self.densities)

    def _sum(self, method, F):
        out = None
        for d in self.densities:
            value = getattr(d, method, d.tangent)(F)  # the tangent where a density has no safe one
            out = value if out is None else out + value
        return out

    def energy(self, F):
        return self._sum("energy", F)

    def stress(self, F):
        return self._sum("stress", F)

    def tangent(self, F):
        return self._sum("safe_tangent" if self.safe else "tangent", F)


class Inertia(Term):
    """Backward Euler's inertia ``1/(2 dt^2) (x - x~)^T M (x - x~)``, ``x~ = u^n + dt v^n`` (set by the
    stepper), ``M`` the lumped or consistent mass of density ``rho0``; ``dt`` may change between steps."""

    name = "inertia"
    quadratic = True
    rank = 0

    def __init__(self, assembler, dt, density, mass="lumped"):
        self.mass_kind = string("mass", mass, ("lumped", "consistent"))
        self.dt = check_time_step(dt)  # dt^2 divides the mass: a closed range, neither end open
        self.density = check_density(density)
        self.assembler, self.lumped = assembler, mass == "lumped"
        self.mass_data = assembler.mass(self.density, lumped=self.lumped)
        self.M = assembler.csr(self.mass_data)
        self._diagonal = self.M.diagonal() if self.lumped else None
        self.x_tilde = np.zeros(assembler.n_dofs)

    def matvec(self, w) -> np.ndarray:  # M w
        return self._diagonal * w if self.lumped else self.M @ w

    def energy(self, u):
        d = u - self.x_tilde
        return 0.5 * dot(d, self.matvec(d)) / self.dt**2

    def gradient(self, u):
        return self.matvec(u - self.x_tilde) / self.dt**2

    def add_hessian(self, u, data, safe=False):
        self.pattern.add_base(data, self.mass_data / self.dt**2)

    def kinetic_energy(self, v) -> float:
        return 0.5 * dot(v, self.matvec(v))

    def momentum(self, v) -> np.ndarray:
        p, d = self.matvec(v), getattr(self.assembler, "dim", 2)
        return np.array([p[i::d].sum() for i in range(d)])

    def describe(self):
        return f"inertia: dt = {self.dt:g}, {self.mass_kind} mass, rho0 = {self.density:g}"

    def remap(self, meshmap):
        return lambda model: Inertia(model.assembler, self.dt, self.density, self.mass_kind)


class Load(Term):
    """A constant external force ``f`` (a dof vector): energy ``-scale f . u`` (``scale`` ramps it in load steps).
    ``make(model) -> f`` makes it again on a remapped mesh (a bare vector cannot be carried)."""

    quadratic = True
    rank = 9

    def __init__(self, name, vector, make=None):
        self.name = name
        self.make = make
        self.vector = np.asarray(vector, dtype=float)
        if not np.all(np.isfinite(self.vector)):
            raise ValueError(f"{name}: the load vector must be finite")
        self.scale = 1.0

    def energy(self, u):
        return -self.scale * dot(self.vector, u)

    def gradient(self, u):
        return -self.scale * self.vector

    def add_hessian(self, u, data, safe=False):
        pass

    def describe(self):
        return f"load: {self.name}"

    def remap(self, meshmap):
        if self.make is None:
            return super().remap(meshmap)
        return lambda model: Load(self.name, self.make(model), self.make)


def node_blocks(nodes, block, dim) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The Hessian entries ``(rows, cols, values)`` of ``block[a, b, p]`` ``(m, m, n)``, the coupling of the nodes
    ``nodes[a, p]`` and ``nodes[b, p]`` ``(m, n)``, in each of the ``dim`` components alike."""
    m = nodes.shape[0]
    rows = np.repeat(nodes[:, None, :], m, axis=1).ravel()
    cols = np.repeat(nodes[None, :, :], m, axis=0).ravel()
    return (np.concatenate([dim * rows + i for i in range(dim)]), np.concatenate([dim * cols + i for i in range(dim)]),
            np.tile(block.ravel(), dim))


def refuse_3d(effect: str, X) -> None:
    """A :class:`ParameterError` naming ``effect`` if the points ``X`` are 3D: the effects still 2D only (self-contact,
    cuts and their ghost penalty) refuse a tetrahedron mesh where they enter."""
    if np.shape(X)[0] != 2:
        raise ParameterError(effect, f"{effect}: this effect is 2D only for now; the mesh has tetrahedra (points "
                                     f"shaped {np.shape(X)})")


def extent(X) -> tuple[np.ndarray, float]:
    """The centre of the bounding box of the points ``X`` ``(d, n)`` and its largest side (the domain's size)."""
    lo, hi = X.min(axis=1), X.max(axis=1)
    return 0.5 * (lo + hi), float(np.max(hi - lo))


def boundary_lengths(mesh) -> np.ndarray:
    """Each vertex's share of the boundary's measure (a probe's weights): its length on triangles, half of every
    boundary edge to each of its ends; its area on tetrahedra, a third of every boundary triangle to each of its
    corners (0 inside)."""
    p = np.asarray(mesh.p, dtype=float)
    facets = mesh.facets[:, mesh.boundary_facets()]  # (d, n_facets): a facet's d corners
    d1 = p[:, facets[1]] - p[:, facets[0]]
    if p.shape[0] == 2:
        measure = vector_length(d1)
    else:  # a triangle's area: half the length of the cross product of two of its sides
        measure = 0.5 * vector_length(np.cross(d1, p[:, facets[2]] - p[:, facets[0]], axis=0))
    share = measure / facets.shape[0]  # a half (the exact 0.5 * length of 2D) or a third to each corner
    return np.bincount(facets.ravel(), weights=np.tile(share, facets.shape[0]), minlength=mesh.nvertices)


def surface_lengths(meshmap) -> np.ndarray:
    """Each node's share of the material's surface after a topology change ``meshmap`` (a probe's weights): the
    length of where the material ends (``meshmap.contact_surface()``, else the mesh's
    boundary: :func:`boundary_lengths`), each point's half of its segments shared among its nodes by its weights. A
    mesh cut through elements has boundary facets that are partly or wholly phantom (a copy of a triangle holds only
    its piece): only their material parts count. A node without material at its place (a virtual node,
    ``meshmap.material``) carries nothing, its place being beyond the lip, where the tool may press the other piece:
    a point's share goes to its nodes with material (the total is the surface's length)."""
    mesh, material = meshmap.mesh, meshmap.material
    surface = meshmap.contact_surface()
    if surface is None:
        return boundary_lengths(mesh) if material is None else np.where(material, boundary_lengths(mesh), 0.0)
    weights = surface.weights if material is None else surface.weights * material[surface.nodes]
    total = weights.sum(axis=1, keepdims=True)
    weights = np.divide(weights, total, out=np.zeros_like(weights), where=total > 0)
    ends = surface.segment_positions(np.asarray(mesh.p, dtype=float))  # (segment, end, xy), reference
    half = 0.5 * np.hypot(*(ends[:, 1] - ends[:, 0]).T)  # half of each segment to each of its ends
    out = np.zeros(mesh.nvertices)
    for end in surface.segments:
        np.add.at(out, surface.nodes[end].ravel(), (weights[end] * half[:, None]).ravel())
    return out


def traction_vector(basis, boundary, traction) -> np.ndarray:
    """``f_(a,i) = int_boundary N_a t_i dS`` for a constant traction ``t`` (force per unit reference length, or
    area on tetrahedra)."""
    mesh = basis.mesh
    t = check_bounded_vector(f"tractions[{boundary!r}]", traction, FORCE_MAX, mesh.p.shape[0])
    if mesh.boundaries is None or boundary not in mesh.boundaries:
        names = sorted(mesh.boundaries) if mesh.boundaries else []
        raise ParameterError("tractions", f"tractions: {boundary!r} is not a boundary of the mesh; boundaries: {names}")
    facets = mesh.boundaries[boundary]
    if len(facets) == 0:
        return np.zeros(basis.N)
    order = 2 if basis.elem.elem.maxdeg > 1 else 1
    fb = FacetBasis(mesh, basis.elem, facets=facets, intorder=2 * order)

    @LinearForm
    def traction_form(v, w):
        return sum(t[i] * v[i] for i in range(t.size))

    return asm(traction_form, fb)


class Probe(Term):
    """A rigid disc (a tool tip; a ball on tetrahedra) of centre ``c`` and radius ``R`` pressed into the tissue's
    surface.

    A penalty pressure on each *boundary* node ``a``, weighted by its share ``l_a`` of the boundary's length (its
    area on tetrahedra: :func:`boundary_lengths`; of the material's surface on a mesh cut through elements:
    :func:`surface_lengths`), at the penetration ``g_a = R - d_a``, ``d_a = |x_a - c|``:

        E = sum_a k l_a h(g_a),   h(g) = g^3 / (6 delta)             (0 < g < delta),
                                  h(g) = g^2/2 - delta g/2 + delta^2/6  (g >= delta),

    ``h = 0`` outside. ``k`` is a pressure per unit penetration, so the penetration does not depend on the
    element size; ``h`` is C2 (smoothed over ``delta``, a small fraction of ``R``), so the Newton matrix does
    not jump as nodes enter or leave. With ``n_a = (x_a - c) / d_a`` the force is ``k l_a h'(g) n_a`` and the
    Hessian ``k l_a [h''(g) n n^T - h'(g)/d (I - n n^T)]`` (``d x d`` blocks, ``d`` the mesh's dimension); its
    tangential part (the disc's curvature) is negative and of order ``g / R``: the *safe* Hessian (``safe=True``,
    the minimiser's fallback) keeps only the normal part.
    """

    name = "probe"
    rank = 2
    has_safe_hessian = True  # the normal part of the Hessian is positive semi-definite

    def __init__(self, X, boundary_lengths, center, radius, stiffness, label=None, smoothing=0.02):
        self.X = X
        self.dim, self.n_nodes = X.shape
        self.length = np.asarray(boundary_lengths, dtype=float)
        self.surface = np.flatnonzero(self.length > 0)
        self._middle, self._size = extent(X)
        self.move(center)
        self.radius = check_radius("probe.radius", check_real("probe.radius", radius, 0.0, lo_open=True), self._size)
        # against the stiffest material: the model checks it against its own (effects.youngs_modulus)
        self.stiffness = check_penalty_stiffness("probe.stiffness", stiffness, YOUNGS_MODULUS_RANGE[1], self.radius)
        # g^3 / (6 delta): a smoothing length far below the radius would overflow the energy
        self.smoothing = check_real("probe.smoothing", smoothing, 1e-6, 1.0)
        self.delta = self.smoothing * self.radius
        self.label = label

    def remap(self, meshmap):
        # the remapped model's surface weights (surface_lengths: the material's parts of the boundary facets)
        return lambda model: Probe(model.X, model.boundary_lengths, self.center, self.radius, self.stiffness,
                                   self.label, self.smoothing)

    def move(self, center) -> None:
        """Move the tool to ``center`` (a point of the mesh's dimension, within ``REACH`` domain sizes of the domain's
        centre); a refusal keeps it."""
        self.center = check_reach("probe center", check_vector("probe center", center, self.dim), self._middle,
                                  self._size)

    def describe(self):
        shape, at = "disc" if self.dim == 2 else "ball", ", ".join(f"{c:g}" for c in self.center)
        return f"probe: {shape} r = {self.radius:g} at ({at}), k = {self.stiffness:g}"

    def _contact(self, u):
        """The surface nodes inside the disc: ``(nodes, penetration g, outward normals n, distances d)``."""
        nodes, d = self.surface, self.dim
        x = self.X[:, nodes] + u[: d * self.n_nodes].reshape(-1, d).T[:, nodes]
        d_vec = x - self.center[:, None]
        distance = vector_length(d_vec)
        inside = distance < self.radius
        dd = distance[inside]
        safe = np.maximum(dd, 1e-12 * self.radius)
        n = d_vec[:, inside] / safe
        n[:, dd < 1e-12 * self.radius] = np.eye(d)[:, [1]]  # at the very centre: push up (+y)
        return nodes[inside], self.radius - dd, n, safe

    def _h(self, g):
        """``h, h', h''`` of the smoothed penalty at penetrations ``g > 0``."""
        delta = self.delta
        cubic = g < delta
        h = np.where(cubic, g**3 / (6 * delta), 0.5 * g**2 - 0.5 * delta * g + delta**2 / 6)
        h1 = np.where(cubic, g**2 / (2 * delta), g - 0.5 * delta)
        h2 = np.where(cubic, g / delta, 1.0)
        return h, h1, h2

    def energy(self, u):
        nodes, g, _, _ = self._contact(u)
        return self.stiffness * float(np.sum(self.length[nodes] * self._h(g)[0]))

    def gradient(self, u):
        nodes, g, n, _ = self._contact(u)
        out = np.zeros(u.size)
        out.reshape(-1, self.dim)[nodes] = (-self.stiffness * self.length[nodes] * self._h(g)[1] * n).T  # dE/dx
        return out

    def forces(self, u) -> np.ndarray:
        """The contact force on every node ``(d, n_nodes)`` (zero off the disc)."""
        return -self.gradient(u)[: self.dim * self.n_nodes].reshape(-1, self.dim).T

    def penetration(self, u) -> float:
        """The deepest any surface node is inside the disc (0 when none is)."""
        _, g, _, _ = self._contact(u)
        return float(g.max(initial=0.0))

    def add_hessian(self, u, data, safe=False):
        nodes, g, n, d = self._contact(u)
        if nodes.size == 0:
            return
        _, h1, h2 = self._h(g)
        w = self.stiffness * self.length[nodes]
        normal, tangential = w * h2, (0.0 if safe else -w * h1 / d)
        for i in range(self.dim):
            for j in range(self.dim):
                nn = n[i] * n[j]
                block = normal * nn + tangential * ((i == j) - nn)
                np.add.at(data, self.pattern.node_block[i, j, nodes], block)


class Sutures(ConstantHessian):
    """Stiff springs that tie pairs of points together: ``E = sum_s k/2 |x_a - x_b - g_s|^2``.

    An end is a node, or a point inside an element that moves with its nodes, ``x_a = sum_c w_c x_{n_c}``
    (barycentric weights ``w``). A suture is placed with its gap as slack ``g_0`` (no force) and *tightened*:
    ``tighten(s)`` sets ``g = (1 - s) g_0``, ``s = 1`` closes the wound. The Hessian ``k D^T D`` (``D``: nodes
    to gap) is constant and couples the ends' nodes (a widened pattern). ``k``: force per unit length.

    ``X`` ``(d, n_nodes)`` (``d``: 2 on triangles, 3 on tetrahedra); ``pairs`` ``(2, k)`` node pairs or, with
    ``coefficients`` ``(2, c, k)`` (each end's weights, adding up to 1: 3 in a triangle, 4 in a tetrahedron),
    each end's ``c`` nodes; ``stiffness`` one number or ``(k,)``; ``gaps`` ``(d, k)``.
    """

    name = "sutures"
    rank = 3

    def __init__(self, X, pairs, stiffness, gaps, tightness=0.0, coefficients=None):
        self.X = X
        self.dim, self.n_nodes = X.shape
        try:
            pairs = np.asarray(pairs)
        except (TypeError, ValueError):  # ragged lists
            raise ValueError(f"sutures.pairs must be node index pairs shaped (2, k), got {pairs!r:.200}") from None
        if not np.issubdtype(pairs.dtype, np.integer) or pairs.ndim not in (2, 3) or pairs.shape[0] != 2 \
                or pairs.shape[-1] == 0 or (pairs.ndim == 3 and coefficients is None):
            raise ValueError(f"sutures.pairs must be node index pairs shaped (2, k), got {pairs!r:.200}")
        if pairs.min() < 0 or pairs.max() >= self.n_nodes:
            raise ValueError(f"sutures.pairs has node indices outside the mesh (0..{self.n_nodes - 1})")
        if pairs.ndim == 2:
            nodes, coef = pairs[:, None, :], np.ones((2, 1, pairs.shape[1]))
            if np.any(pairs[0] == pairs[1]):
                raise ValueError("sutures.pairs ties a node to itself")
        else:
            nodes = pairs
            coef = check_real_array("sutures.coefficients", coefficients)
            if coef.shape != nodes.shape or not np.all(np.isfinite(coef)) or np.any(np.abs(coef) > 10.0) \
                    or not np.allclose(coef.sum(axis=1), 1.0, atol=1e-9):
                raise ValueError(f"sutures.coefficients must be barycentric weights shaped {nodes.shape} "
                                 "(each end's weights in [-10, 10], adding up to 1)")
        self.nodes, self.coefficients = nodes.astype(np.intp), coef
        k_count = nodes.shape[-1]
        #: node pairs (2, k): each end's node of largest weight (the node itself for node-to-node stitches)
        self.pairs = np.take_along_axis(self.nodes, np.argmax(coef, axis=1)[:, None, :], axis=1)[:, 0, :]
        k = check_real_array("sutures.stiffness", stiffness)
        try:
            k = np.broadcast_to(k, (k_count,)).copy()
        except ValueError:
            raise ValueError(f"sutures.stiffness must be one number or one per stitch ({k_count}), "
                             f"got shape {k.shape}") from None
        # the first NaN, infinite or non-positive one, else the stiffest, against the stiffest material (a model
        # checks it against its own: effects.youngs_modulus)
        worst = k[~(np.isfinite(k) & (k > 0))]
        check_penalty_stiffness("sutures.stiffness", worst[0] if worst.size else k.max(), YOUNGS_MODULUS_RANGE[1],
                                positive=True)
        self.k = k
        gaps = check_real_array("sutures.gaps", gaps)
        reach = REACH * extent(X)[1]
        if gaps.shape != (self.dim, k_count) or not np.all(np.abs(gaps) <= reach):
            raise ValueError(f"sutures.gaps must be finite, within {REACH:g} domain sizes ({reach:g}) and shaped "
                             f"{(self.dim, k_count)}, got shape {gaps.shape}")
        self.gap0, self.tightness = gaps, np.zeros(k_count)
        self.tighten(tightness)  # sets the slack

    def tighten(self, fraction, stitches=None) -> None:
        """Set the tightness (0 slack ... 1 closed) of all stitches or of the ``stitches`` (indices):
        ``fraction`` one number in ``[0, 1]`` or one per stitch. All or nothing."""
        count = self.pairs.shape[1]
        if isinstance(stitches, numbers.Integral) and not isinstance(stitches, (bool, np.bool_)):
            stitches = [stitches]
        index = np.arange(count) if stitches is None else check_indices("stitches", stitches, count)
        s = check_real_array("fraction (suture tightness)", fraction)
        if s.ndim > 1 or (s.ndim == 1 and s.shape != index.shape):
            raise ValueError(f"fraction (suture tightness) must be one number or one per stitch tightened "
                             f"({index.size}), got shape {s.shape}")
        if not (np.all(np.isfinite(s)) and np.all(s >= 0) and np.all(s <= 1)):
            raise ValueError(f"fraction (suture tightness) must be in [0, 1], got {fraction!r}")
        tightness = self.tightness.copy()
        tightness[index] = s
        self.tightness = tightness
        self.slack = (1.0 - self.tightness) * self.gap0

    def describe(self):
        return f"sutures: {self.k.size} stitches, mean tightness {self.tightness.mean():g}"

    def remap(self, meshmap):
        """Each end on the first copy of its nodes (a cut through an end's element may need a better choice:
        the surgery layer carries its stitches as points of the material); stitches on removed nodes go."""
        first = np.full(meshmap.n_old_nodes, -1, dtype=np.intp)
        first[meshmap.parent[::-1]] = np.arange(meshmap.parent.size - 1, -1, -1)
        nodes = first[self.nodes]
        keep = np.all(nodes >= 0, axis=(0, 1))
        if not np.any(keep):
            return None
        return Sutures(np.asarray(meshmap.mesh.p, dtype=float), nodes[..., keep], self.k[keep], self.gap0[:, keep],
                       self.tightness[keep], coefficients=self.coefficients[..., keep])

    def ends(self, u) -> np.ndarray:
        """Where the two ends of every stitch are: shape (2 ends, d coordinates, k)."""
        x = self.X + u[: self.dim * self.n_nodes].reshape(-1, self.dim).T
        return np.einsum("sck,iksc->sik", self.coefficients, x[:, self.nodes.transpose(2, 0, 1)])

    def _gap(self, u):
        a, b = self.ends(u)
        return a - b - self.slack

    def energy(self, u):
        e = self._gap(u)
        return 0.5 * float(np.sum(self.k * np.sum(e**2, axis=0)))

    def gradient(self, u):
        e = self.k * self._gap(u)  # (d, k): the spring force on end a (minus on end b)
        signed = self.coefficients * np.array([1.0, -1.0])[:, None, None]  # (2, c, k)
        g = np.zeros(u.size)
        for i in range(self.dim):
            np.add.at(g, self.dim * self.nodes.ravel() + i, (signed * e[i]).ravel())
        return g

    def distances(self, u) -> np.ndarray:  # how far apart the two ends of each stitch are
        a, b = self.ends(u)
        return vector_length(a - b)

    def forces(self, u) -> np.ndarray:
        """The tension ``k |x_a - x_b - g|`` in each stitch."""
        return self.k * vector_length(self._gap(u))

    def entries(self):
        # D maps node displacements to the gap: +w on end a's nodes, -w on end b's; the Hessian is k D^T D
        signed = (self.coefficients * np.array([1.0, -1.0])[:, None, None]).reshape(-1, self.k.size)  # (2c, k)
        w = signed[:, None, :] * signed[None, :, :] * self.k
        return node_blocks(self.nodes.reshape(-1, self.k.size), w, self.dim)
