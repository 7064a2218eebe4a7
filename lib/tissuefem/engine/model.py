"""A model composed of exactly the energy terms a scene calls for.

The total potential of a (quasistatic) tissue is a sum of terms,

    E(u) = sum_terms E_term(u) - f_ext . u,

and backward Euler adds the inertia term ``1/2 |u - u_tilde|_M^2`` on top
(see :mod:`tissuefem.realtime`). Each term here knows its energy, its
gradient (a force vector) and its Hessian; the :class:`Model` adds up only the
terms it was built with. A scene without fibres has no fibre term, so no fibre
code runs; a scene without a probe has no contact term; a quasistatic scene
never builds a mass matrix (the solver builds it only for a time step).

Terms (all on P1 triangles, displacement dofs interleaved ``(2a, 2a+1)``):

* :class:`Elastic` -- ``sum_e A_e Psi(F_e)`` of the isotropic material;
* :class:`Fibers` -- ``sum_e A_e k/8 (|F_e g_e|^2 - 1)^2``, the fibre energy of
  chapter 5 as a term of its own (so its cost can be measured);
* :class:`Probe` -- a rigid disc pressed into the tissue, a penalty on the
  nodes that enter it;
* :class:`Sutures` -- stiff zero-length springs tying pairs of nodes together;
* constant loads (gravity, tractions) go into ``external``: their energy is
  ``-f_ext . u``.

Handles (prescribed displacements) are not terms: the solver eliminates their
dofs. :class:`NodeHandle` is a handle on a set of mesh nodes that a frame may
move (a scene's fixed edge, a user's grab).

The model has the interface :class:`tissuefem.realtime.RealtimeSolver`
expects of a problem (``basis``, ``handles``, ``external``, ``prescribed``,
``strain_energy``, ``internal_force``, ``tangent``) and acts as its own fast
assembler: ``tangent`` returns CSR matrices on one fixed pattern (the mesh's,
widened by the suture springs' couplings).
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from skfem import Basis, ElementTriP1, ElementVector, LinearForm, asm

from .assembly import P1Assembler
from .quasistatic import Handle
from .materials import FiberReinforced, Material, fiber_energy_term, fiber_stress_term, fiber_tangent_term


def _vector2(name, value) -> np.ndarray:
    try:
        v = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a finite vector (x, y), got {value!r}") from None
    if v.shape != (2,) or not np.all(np.isfinite(v)):
        raise ValueError(f"{name} must be a finite vector (x, y), got {value!r}")
    return v


def _nonnegative(name, value) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a finite number >= 0, got {value!r}") from None
    if not (np.isfinite(v) and v >= 0):
        raise ValueError(f"{name} must be a finite number >= 0, got {value!r}")
    return v


# ---------------------------------------------------------------------------------------------------------------
# handles
# ---------------------------------------------------------------------------------------------------------------

class NodeHandle:
    """Mesh nodes held at prescribed positions.

    The prescribed displacement of node ``a`` is ``base_a + (phi(X_a) - X_a)``
    where ``phi`` is the target: a translation ``(dx, dy)`` (``phi(X) = X + d``)
    or a callable map ``(2, n) -> (2, n)``. ``base`` is zero for a scene's
    handle (a fixed edge, a pulled edge); for a grab it is the nodes'
    displacement at the moment they were grabbed, so the grabbed piece of
    tissue first stays where it is and then follows the mouse by the offset.
    """

    def __init__(self, nodes, target=(0.0, 0.0), base=None, name=None):
        nodes = np.asarray(nodes)
        if nodes.ndim != 1 or nodes.size == 0 or not np.issubdtype(nodes.dtype, np.integer) or nodes.min() < 0:
            raise ValueError(f"handle nodes must be a non-empty 1D array of node indices, got {nodes!r}")
        self.nodes = np.unique(nodes).astype(np.intp)
        if base is None:
            base = np.zeros((2, self.nodes.size))
        base = np.asarray(base, dtype=float)
        if base.shape != (2, self.nodes.size) or not np.all(np.isfinite(base)):
            raise ValueError(f"handle base displacement must be finite and shaped (2, {self.nodes.size})")
        self.base = base
        self.name = name
        self.move(target)

    # the target's checks and its map are those of the quasistatic Handle
    move = Handle.move
    positions = Handle.positions

    def displacement(self, X) -> np.ndarray:
        """Prescribed displacement ``(2, n)`` of the handle's nodes, whose reference positions are ``X``."""
        return self.base + (self.positions(X) - X)

    def remap(self, parent) -> "NodeHandle | None":
        """The same handle on a mesh whose node ``i`` comes from old node ``parent[i]`` (after a cut or an
        excision): every copy of a held node is held, with its parent's base displacement. ``None`` if none
        of its nodes survives."""
        parent = np.asarray(parent, dtype=np.intp)
        where = np.full(max(int(parent.max(initial=0)), int(self.nodes.max())) + 1, -1, dtype=np.intp)
        where[self.nodes] = np.arange(self.nodes.size)
        index = where[parent]
        new_nodes = np.flatnonzero(index >= 0)
        if new_nodes.size == 0:
            return None
        h = NodeHandle(new_nodes, base=self.base[:, index[new_nodes]], name=self.name)
        h.target = self.target
        return h

    def __repr__(self):
        return f"NodeHandle({self.nodes.size} nodes, target={self.target!r}, name={self.name!r})"


# ---------------------------------------------------------------------------------------------------------------
# terms
# ---------------------------------------------------------------------------------------------------------------

class Term:
    """One additive piece of the potential: ``energy(u)``, ``gradient(u)``, and its Hessian.

    ``add_hessian(u, data, model)`` adds the term's Hessian into ``data``, the
    CSR data array of the model's fixed pattern. ``quadratic`` is True when the
    energy is a quadratic function of ``u`` (a constant Hessian).
    """

    name = "term"
    quadratic = False

    def describe(self) -> str:
        return self.name

    def __repr__(self):
        return f"<{self.describe()}>"


class _Assembled(Term):
    """A term that is a material's energy summed over the elements by the fast P1 assembler."""

    def energy(self, u):
        return self.assembler.energy(u, self.material)

    def gradient(self, u):
        return self.assembler.residual(u, self.material)

    def hessian_data(self, u):
        return self.assembler.tangent(u, self.material).data


class Elastic(_Assembled):
    """The stored energy of the (isotropic) material, through the fast P1 assembler."""

    name = "elastic"

    def __init__(self, assembler: P1Assembler, material):
        self.assembler = assembler
        self.material = material
        self.quadratic = getattr(material, "name", "") == "linear"

    def describe(self):
        return f"elastic: {getattr(self.material, 'name', type(self.material).__name__)}"



class _FiberOnly(Material):
    """Only the fibre part ``k/8 (I4 - 1)^2`` (no matrix material), for the P1 assembler."""

    name = "fibers"

    def __init__(self, stiffness, fibers):
        self.lam = self.mu = 0.0
        # reuse the checks (normalisation, shapes) of FiberReinforced
        self.fibers = FiberReinforced._check_fibers(fibers)
        self.stiffness = float(stiffness)

    def _g(self, F):
        g = self.fibers
        return g if g.ndim == 2 or F.ndim == 2 else g.reshape((2,) + (1,) * (F.ndim - 2))

    def energy(self, F):
        return fiber_energy_term(F, self._g(F), self.stiffness)

    def stress(self, F):
        return fiber_stress_term(F, self._g(F), self.stiffness)

    def tangent(self, F):
        return fiber_tangent_term(F, self._g(F), self.stiffness)


class Fibers(_Assembled):
    """The fibre energy ``k/8 (I4 - 1)^2`` per element (chapter 5), added to any material."""

    name = "fibers"

    def __init__(self, assembler: P1Assembler, stiffness, directions):
        self.assembler = assembler
        self.stiffness = _nonnegative("fibers.stiffness", stiffness)
        g = np.asarray(directions, dtype=float)
        if g.ndim == 1:
            g = np.repeat(g.reshape(2, 1), assembler.n_elements, axis=1)
        if g.shape != (2, assembler.n_elements):
            raise ValueError(
                f"fibers.direction must be shaped (2,) or (2, n_elements={assembler.n_elements}), got {g.shape}"
            )
        self.material = _FiberOnly(self.stiffness, g)
        self.directions = self.material.fibers

    def describe(self):
        return f"fibers: k = {self.stiffness:g}"



class Probe(Term):
    """A rigid disc (a tool tip) of centre ``c`` and radius ``R`` that the tissue's nodes must stay out of.

    A penalty on each node ``a`` that enters the disc, weighted by its lumped
    area ``m_a`` so that the stiffness ``k`` is per unit area:

        E = sum_a k m_a / 2 (R - d_a)^2  for d_a = |x_a - c| < R,

    with ``x_a = X_a + u_a``. With ``n_a = (x_a - c) / d_a`` the force on the
    node is ``-dE/dx_a = k m_a (R - d_a) n_a`` (outward), and the Hessian is
    ``k m_a [n n^T - (R - d)/d (I - n n^T)]``. Its tangential part is negative
    (the disc's curved surface), so the Newton matrix keeps only the positive
    ``k m_a n n^T`` (a Gauss-Newton approximation; the energy line search makes
    the step safe). The tool moves between frames through :meth:`move`.
    """

    name = "probe"

    def __init__(self, X, node_areas, center, radius, stiffness, label=None):
        self.X = X
        self.m = node_areas
        self.move(center)
        self.radius = _nonnegative("probe.radius", radius)
        if self.radius == 0:
            raise ValueError("probe.radius must be > 0")
        self.stiffness = _nonnegative("probe.stiffness", stiffness)
        self.label = label

    def move(self, center) -> None:
        self.center = _vector2("probe center", center)

    def describe(self):
        return f"probe: disc r = {self.radius:g} at ({self.center[0]:g}, {self.center[1]:g}), k = {self.stiffness:g}"

    def _contact(self, u):
        x = self.X + u.reshape(-1, 2).T
        d_vec = x - self.center[:, None]
        d = np.hypot(d_vec[0], d_vec[1])
        inside = np.flatnonzero(d < self.radius)
        dd = d[inside]
        safe = np.maximum(dd, 1e-12 * self.radius)
        n = d_vec[:, inside] / safe
        n[:, dd < 1e-12 * self.radius] = np.array([[0.0], [1.0]])  # at the very centre: push up
        return inside, self.radius - dd, n

    def energy(self, u):
        inside, depth, _ = self._contact(u)
        return 0.5 * self.stiffness * float(np.sum(self.m[inside] * depth**2))

    def gradient(self, u):
        inside, depth, n = self._contact(u)
        g = np.zeros(u.size)
        f = -self.stiffness * self.m[inside] * depth * n  # dE/dx
        g[2 * inside] = f[0]
        g[2 * inside + 1] = f[1]
        return g

    def penetration(self, u) -> float:
        """The deepest any node is inside the disc (0 when none is)."""
        _, depth, _ = self._contact(u)
        return float(depth.max(initial=0.0))

    def add_hessian(self, u, data, model):
        inside, _, n = self._contact(u)
        if inside.size == 0:
            return
        w = self.stiffness * self.m[inside]
        for i in range(2):
            for j in range(2):
                np.add.at(data, model.node_block[i, j, inside], w * n[i] * n[j])


class Sutures(Term):
    """Stiff springs that tie pairs of nodes together: ``E = sum_s k/2 |x_a - x_b - g_s|^2``.

    ``g_s`` is the slack: the gap the suture still allows. A suture is placed
    with its current gap as slack (no force at first) and then *tightened*:
    ``tighten(s)`` sets ``g = (1 - s) g_0``, so ``s = 1`` closes the wound.
    Every term is quadratic (a zero-length spring), so the Hessian is constant;
    it couples the two nodes of each pair, which widens the model's pattern.
    ``k`` is a force per unit length (per unit thickness, in 2D).
    """

    name = "sutures"
    quadratic = True

    def __init__(self, X, pairs, stiffness, gaps):
        self.X = X
        pairs = np.asarray(pairs)
        if pairs.ndim != 2 or pairs.shape[0] != 2 or pairs.shape[1] == 0 or not np.issubdtype(pairs.dtype, np.integer):
            raise ValueError(f"sutures.pairs must be node index pairs shaped (2, k), got {pairs!r}")
        if np.any(pairs[0] == pairs[1]):
            raise ValueError("sutures.pairs ties a node to itself")
        self.pairs = pairs.astype(np.intp)
        k = np.broadcast_to(np.asarray(stiffness, dtype=float), (self.pairs.shape[1],)).copy()
        if not np.all(np.isfinite(k) & (k > 0)):
            raise ValueError(f"sutures.stiffness must be finite and > 0, got {stiffness!r}")
        self.k = k
        gaps = np.asarray(gaps, dtype=float)
        if gaps.shape != self.pairs.shape or not np.all(np.isfinite(gaps)):
            raise ValueError(f"sutures.gaps must be finite and shaped {self.pairs.shape}, got {gaps.shape}")
        self.gap0 = gaps
        self.tightness = np.zeros(self.pairs.shape[1])
        self.slack = self.gap0.copy()

    def tighten(self, fraction, stitches=None) -> None:
        """Set the tightness (0 slack ... 1 closed) of all stitches, or of those indexed by ``stitches``."""
        s = np.asarray(fraction, dtype=float)
        if not (np.all(np.isfinite(s)) and np.all(s >= 0) and np.all(s <= 1)):
            raise ValueError(f"suture tightness must be in [0, 1], got {fraction!r}")
        index = slice(None) if stitches is None else np.asarray(stitches, dtype=np.intp)
        tightness = self.tightness.copy()
        tightness[index] = s
        self.tightness = tightness
        self.slack = (1.0 - self.tightness) * self.gap0

    def describe(self):
        return f"sutures: {self.pairs.shape[1]} stitches, mean tightness {self.tightness.mean():g}"

    def _gap(self, u):
        x = self.X + u.reshape(-1, 2).T
        return x[:, self.pairs[0]] - x[:, self.pairs[1]] - self.slack

    def energy(self, u):
        e = self._gap(u)
        return 0.5 * float(np.sum(self.k * (e[0] ** 2 + e[1] ** 2)))

    def gradient(self, u):
        e = self.k * self._gap(u)
        g = np.zeros(u.size)
        for i in range(2):
            np.add.at(g, 2 * self.pairs[0] + i, e[i])
            np.add.at(g, 2 * self.pairs[1] + i, -e[i])
        return g

    def distances(self, u) -> np.ndarray:
        """How far apart each sutured pair is (0 when closed)."""
        x = self.X + u.reshape(-1, 2).T
        d = x[:, self.pairs[0]] - x[:, self.pairs[1]]
        return np.hypot(d[0], d[1])

    def forces(self, u) -> np.ndarray:
        """The tension ``k |x_a - x_b - g|`` in each stitch."""
        e = self._gap(u)
        return self.k * np.hypot(e[0], e[1])

    def triplets(self):
        """Rows, columns and values of the constant Hessian (4 blocks ``k I`` per stitch)."""
        a, b = self.pairs
        rows, cols, vals = [], [], []
        for p, q, sign in ((a, a, 1.0), (b, b, 1.0), (a, b, -1.0), (b, a, -1.0)):
            for i in range(2):
                rows.append(2 * p + i)
                cols.append(2 * q + i)
                vals.append(sign * self.k)
        return np.concatenate(rows), np.concatenate(cols), np.concatenate(vals)


# ---------------------------------------------------------------------------------------------------------------
# the model
# ---------------------------------------------------------------------------------------------------------------

class Model:
    """The potential of one scene: the terms it names and nothing else.

    Parameters
    ----------
    mesh : skfem.MeshTri
    material
        The isotropic material (possibly wrapped for inversion handling).
    fibers : (stiffness, directions), optional
        Adds a :class:`Fibers` term.
    handles : list of NodeHandle
    external : array, optional
        Constant loads (gravity, tractions) as a dof vector; see :func:`load_vector`.
    probes : list of dict(center, radius, stiffness), optional
    sutures : dict(pairs, stiffness, gaps[, tightness]), optional
    """

    def __init__(self, mesh, material, *, fibers=None, handles=(), external=None, probes=(), sutures=None,
                 loads=()):
        self.mesh = mesh
        self.material = material
        self.basis = Basis(mesh, ElementVector(ElementTriP1()), intorder=2)
        self.assembler_p1 = P1Assembler(mesh, material)
        n = self.basis.N
        # the interleaved dof layout of the fast assembler is scikit-fem's for vector P1
        if not np.array_equal(self.basis.nodal_dofs, np.arange(n).reshape(-1, 2).T):
            raise RuntimeError("unexpected dof numbering of the vector P1 basis")
        self.X = mesh.p
        self.handles = list(handles)
        for h in self.handles:
            if not isinstance(h, NodeHandle):
                raise ValueError(f"handles must be NodeHandle objects, got {h!r}")
            if h.nodes.max() >= mesh.nvertices:
                raise ValueError(f"handle {h.name!r} has node indices outside the mesh (0..{mesh.nvertices - 1})")
        self.external = np.zeros(n) if external is None else np.asarray(external, dtype=float).copy()
        if self.external.shape != (n,) or not np.all(np.isfinite(self.external)):
            raise ValueError(f"external must be a finite vector of shape ({n},)")
        #: names of the constant loads included in ``external`` (for the term list)
        self.loads = list(loads)

        self.terms: list[Term] = [Elastic(self.assembler_p1, material)]
        if fibers is not None:
            self.terms.append(Fibers(self.assembler_p1, *fibers))
        # lumped area per node: a third of each incident triangle (t.ravel() lists vertex 0 of every element, ...)
        self.node_areas = np.bincount(self.assembler_p1.t.ravel(), weights=np.tile(self.assembler_p1.areas / 3.0, 3),
                                      minlength=mesh.nvertices)
        self.probes = [Probe(self.X, self.node_areas, **p) for p in probes]
        self.terms.extend(self.probes)
        self.sutures = None
        if sutures is not None:
            tightness = sutures.get("tightness", 0.0)
            self.sutures = Sutures(self.X, sutures["pairs"], sutures["stiffness"], sutures["gaps"])
            if self.sutures.pairs.max() >= mesh.nvertices:
                raise ValueError("sutures.pairs has node indices outside the mesh")
            self.sutures.tighten(tightness)
            self.terms.append(self.sutures)
        self._build_pattern()

    # ------------------------------------------------------------------ what is in it
    @property
    def term_names(self) -> list[str]:
        """The energy terms and loads this model evaluates (handles are constraints, not terms)."""
        return [t.name for t in self.terms] + self.loads

    def describe(self) -> list[str]:
        return [t.describe() for t in self.terms] + self.loads

    @property
    def quadratic(self) -> bool:
        """True when every term is quadratic: the Hessian is constant (a linear, small-strain scene)."""
        return all(t.quadratic for t in self.terms)

    # ------------------------------------------------------------------ the pattern
    def _build_pattern(self):
        base = self.assembler_p1
        n = base.n_dofs
        rows = np.repeat(np.arange(n), np.diff(base.indptr))
        base_keys = rows.astype(np.int64) * n + base.indices
        if self.sutures is None:
            keys = base_keys
            self.indptr, self.indices = base.indptr, base.indices
            self._base_pos = None
        else:
            r, c, v = self.sutures.triplets()
            keys = np.union1d(base_keys, r.astype(np.int64) * n + c)
            counts = np.bincount(keys // n, minlength=n)
            self.indptr = np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)
            self.indices = (keys % n).astype(np.int64)
            self._base_pos = np.searchsorted(keys, base_keys)
            self._suture_pos = np.searchsorted(keys, r.astype(np.int64) * n + c)
            self._suture_vals = v
        self.nnz = keys.size
        self.n_dofs = n
        # positions of each node's 2x2 diagonal block (for the probe's Hessian)
        nodes = np.arange(self.mesh.nvertices, dtype=np.int64)
        self.node_block = np.empty((2, 2, nodes.size), dtype=np.intp)
        for i in range(2):
            for j in range(2):
                self.node_block[i, j] = np.searchsorted(keys, (2 * nodes + i) * n + 2 * nodes + j)

    @property
    def assembler(self):
        """The model is its own fast assembler (``tangent``, ``indptr``, ``indices``, ``nnz``, ``n_dofs``)."""
        return self

    def csr(self, data) -> sp.csr_matrix:
        K = sp.csr_matrix((data, self.indices, self.indptr), shape=(self.n_dofs, self.n_dofs), copy=False)
        K.has_sorted_indices = True
        return K

    # ------------------------------------------------------------------ energy, force, Hessian
    def strain_energy(self, u) -> float:
        """The sum of the terms' energies (without the constant loads' ``-f_ext . u``)."""
        return sum(t.energy(u) for t in self.terms)

    def internal_force(self, u) -> np.ndarray:
        g = self.terms[0].gradient(u)
        for t in self.terms[1:]:
            g = g + t.gradient(u)
        return g

    def tangent(self, u) -> sp.csr_matrix:
        elastic = self.terms[0].hessian_data(u)
        for t in self.terms[1:]:
            if isinstance(t, Fibers):
                elastic = elastic + t.hessian_data(u)
        if self._base_pos is None:
            data = elastic
        else:
            data = np.zeros(self.nnz)
            data[self._base_pos] = elastic
            np.add.at(data, self._suture_pos, self._suture_vals)
        for p in self.probes:
            p.add_hessian(u, data, self)
        return self.csr(data)

    def prescribed(self) -> tuple[np.ndarray, np.ndarray]:
        """The held dofs and their displacements (where handles overlap, the later one wins)."""
        if not self.handles:
            return np.zeros(0, dtype=np.intp), np.zeros(0)
        dofs, values = [], []
        for h in self.handles:
            u = h.displacement(self.X[:, h.nodes])
            dofs.append((2 * h.nodes[None, :] + np.arange(2)[:, None]).ravel())
            values.append(u.ravel())
        dofs, values = np.concatenate(dofs), np.concatenate(values)
        unique, first_in_reversed = np.unique(dofs[::-1], return_index=True)
        return unique, values[::-1][first_in_reversed]

    # ------------------------------------------------------------------ post-processing
    def positions(self, u) -> np.ndarray:
        """Deformed node positions ``(2, n_nodes)``."""
        return self.X + np.asarray(u).reshape(-1, 2).T

    def deformation_gradient(self, u) -> np.ndarray:
        return self.assembler_p1.deformation_gradient(u)

    def cauchy_stress(self, u) -> np.ndarray:
        """Cauchy stress ``sigma = P F^T / J`` of every element ``(2, 2, n_elements)`` (all terms' P)."""
        F = self.deformation_gradient(u)
        P = np.broadcast_to(self.material.stress(F), F.shape).copy()
        for t in self.terms:
            if isinstance(t, Fibers):
                P += t.material.stress(F)
        J = F[0, 0] * F[1, 1] - F[0, 1] * F[1, 0]
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.einsum("ike,jke->ije", P, F) / J

    def tension(self, u) -> np.ndarray:
        """The largest principal Cauchy stress of every element (positive = pulled apart)."""
        s = self.cauchy_stress(u)
        mean = 0.5 * (s[0, 0] + s[1, 1])
        radius = np.hypot(0.5 * (s[0, 0] - s[1, 1]), 0.5 * (s[0, 1] + s[1, 0]))
        return mean + radius

    def mass(self, density) -> float:
        """Total mass ``rho0 * area``."""
        return float(density) * float(self.assembler_p1.areas.sum())


def load_vector(basis, body_force=None, tractions=()):
    """Constant external forces: a body force ``b`` per unit area and tractions on named boundaries.

    ``tractions`` is a list of ``(boundary name, (tx, ty))`` (force per unit reference length).
    """
    from skfem import FacetBasis

    f = np.zeros(basis.N)
    if body_force is not None:
        b = _vector2("body force", body_force)

        @LinearForm
        def body(v, w):
            return b[0] * v[0] + b[1] * v[1]

        f += asm(body, basis)
    mesh = basis.mesh
    for name, t in tractions:
        t = _vector2(f"traction on {name!r}", t)
        if mesh.boundaries is None or name not in mesh.boundaries:
            names = sorted(mesh.boundaries) if mesh.boundaries else []
            raise ValueError(f"tractions: {name!r} is not a boundary of the mesh; boundaries: {names}")
        facets = mesh.boundaries[name]
        if len(facets) == 0:
            continue
        fb = FacetBasis(mesh, basis.elem, facets=facets, intorder=2)

        @LinearForm
        def traction(v, w, t=t):
            return t[0] * v[0] + t[1] * v[1]

        f += asm(traction, fb)
    return f
