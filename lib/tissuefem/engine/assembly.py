"""The fast P1 path: vectorised assembly into a fixed sparsity pattern.

On P1 triangles the shape-function gradients are constant per triangle, so ``F = I + grad u`` is one 2x2 matrix per
element and an integral is the area times the integrand. :class:`P1Assembler` computes the energy, forces and tangent
of the forms of :mod:`tissuefem.engine.forms` (to round-off) without a form call per pair of basis functions: once,
areas, gradients, the CSR pattern and a *scatter map* (the CSR data slot of each of the ``36 n_elements`` local
entries); per call, **one** material call on ``F`` shaped ``[2, 2, n_elements]``, ``einsum`` for the local arrays and
one ``np.bincount``. With ``G[a, j] = dN_a/dX_j`` and area ``A_e``::

    F_ij        = d_ij + sum_a u_(a,i) G[a, j]
    E           = sum_e A_e Psi(F_e)
    r_(a,i)     = sum_e A_e P_ij(F_e) G[a, j]                    (= dE/du_(a,i))
    K_(a,i)(b,k) = sum_e A_e A_ijkl(F_e) G[a, j] G[b, l]           (= dr_(a,i)/du_(b,k))

Node ``n`` has dofs ``(2 n, 2 n + 1)``, scikit-fem's order for ``ElementVector(ElementTriP1())``. Clockwise triangles
(scikit-fem sorts vertices) are reoriented in the copy ``self.t``. Measured at 8k triangles: ``np.bincount`` scatters
in ~0.45 ms (``np.add.at`` ~0.57, sort + ``reduceat`` ~2); a plain ``einsum`` on element-last arrays takes ~0.6 ms
(``optimize=True`` is ten times slower).

The same code runs on tetrahedra (:class:`skfem.MeshTet`), the dimension ``d`` read from the mesh: ``F`` is ``d x d``,
node ``n`` has dofs ``d n ... d n + d - 1``, ``A_e`` is the element's volume and the gradients are the rows of the
inverse Jacobian of each element. Only the geometry (orientation, measure, gradients) has a formula per element kind.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from skfem import Basis, ElementTetP1, ElementTetP2, ElementTriP1, ElementTriP2, ElementVector, asm

from .forms import energy_form, residual_form, tangent_form
from .materials import FiberFamily, FiberReinforced
from .meshes import check_mesh
from .parameters import ParameterError, check_count, check_density, check_vector, check_weights
from .vectors import dot

__all__ = ["P1Assembler", "QuadratureAssembler", "FormsAssembler", "make_assembler", "vector_basis", "check_weights",
           "element_geometry"]


class _FixedPattern:
    """What the assemblers share: a default ``material``, the element dofs (row ``d a + i`` of ``element_dofs`` the
    dof ``d n + i`` of the element's node ``a``) and a fixed CSR pattern (``indptr``, ``indices``: shared by every
    matrix returned and read-only, so ``eliminate_zeros`` and the like raise instead of corrupting it)."""

    def _set_pattern(self, nodes, n_nodes) -> None:
        """The dofs and the pattern of elements with the nodes ``nodes`` (n_local, n_elements)."""
        dim = self.dim
        self.n_dofs = dim * n_nodes
        self.element_dofs = (dim * nodes[:, None, :] + np.arange(dim)[None, :, None]).reshape(-1, nodes.shape[1])
        self.element_dofs.setflags(write=False)
        self._dofs_flat = self.element_dofs.reshape(-1).astype(np.intp)
        self.indptr, self.indices, self._scatter = _block_pattern(nodes, n_nodes, dim)
        self.nnz = self.indices.size

    def _material(self, material):
        m = self.material if material is None else material
        if m is None:
            raise ParameterError("material", "material must be given (to the constructor or to this call), got None")
        if not all(callable(getattr(m, name, None)) for name in ("energy", "stress", "tangent")):
            raise ParameterError("material", f"material must have energy, stress and tangent methods, got {m!r}")
        return m

    def _check_u(self, u) -> np.ndarray:
        u = np.asarray(u, dtype=float)
        if u.shape != (self.n_dofs,):
            raise ParameterError("u", f"u must be a displacement vector of shape (n_dofs,) = ({self.n_dofs},) "
                                      f"in scikit-fem's ordering (node n has dofs 2n, 2n+1), got shape {u.shape}")
        return u

    def csr(self, data) -> sp.csr_matrix:
        """A ``n_dofs x n_dofs`` CSR matrix with this assembler's pattern and the given data."""
        data = np.asarray(data, dtype=float)
        if data.shape != (self.nnz,):
            raise ParameterError("data", f"data must have shape (nnz,) = ({self.nnz},), got {data.shape}")
        K = sp.csr_matrix((data, self.indices, self.indptr), shape=(self.n_dofs, self.n_dofs), copy=False)
        K.has_sorted_indices = True
        K.has_canonical_format = True
        return K

    @property
    def diagonal(self) -> np.ndarray:
        """Positions of the diagonal entries in the CSR data array, row by row (every node is in an element, so every
        dof's row holds its diagonal)."""
        return np.flatnonzero(np.repeat(np.arange(self.n_dofs), np.diff(self.indptr)) == self.indices)

    def deformation_gradient(self, u) -> np.ndarray:
        """``F = I + grad u`` of every element (at every quadrature point), shaped ``[d, d, n_elements(, nq)]``."""
        ue = self._check_u(u)[self.element_dofs].reshape(-1, self.dim, self.n_elements)  # ue[a, i, e]
        F = np.einsum("aie,aje...->ije...", ue, self._G)
        F[range(self.dim), range(self.dim)] += 1.0
        return F

    def __repr__(self):
        return (f"{type(self).__name__}({self.n_elements} {'triangles' if self.dim == 2 else 'tetrahedra'}, "
                f"{self.n_dofs} dofs, nnz={self.nnz}, material={self.material!r})")


class P1Assembler(_FixedPattern):
    """Energy, internal forces and tangent of a hyperelastic material on a straight-sided P1 :class:`~skfem.MeshTri`.

    ``material``: the default, which every method's ``material`` overrides. ``weights``: optional ``(n_elements,)``
    fractions in ``(0, 1]`` of each triangle's area its material fills (a cut through elements). Attributes: ``t``
    ``(3, n_elements)`` counter-clockwise (``flipped``: those reoriented); ``areas`` (times the weights);
    ``element_dofs`` ``(6, n_elements)``, row ``2 a + i`` the dof ``2 t[a, e] + i``; ``indptr, indices``.
    """

    def __init__(self, mesh, material=None, weights=None):
        p, t = _mesh_arrays(mesh)
        self.mesh, self.material = mesh, material
        self.dim = p.shape[0]  # 2: triangles, 3: tetrahedra
        self.n_nodes, self.n_elements = p.shape[1], t.shape[1]
        # geometry: orientation, areas (volumes), gradients (element-last layout)
        self.t, self.flipped, self.areas, G = element_geometry(p, t)
        self.t.setflags(write=False)
        if weights is not None:  # a part of an element integrates over that part: its area shrinks, its gradients not
            self.areas = self.areas * check_weights(weights, self.n_elements)
        self._G, self._GA = G, G * self.areas  # and the area-weighted gradients
        self._set_pattern(self.t, self.n_nodes)

    def _material(self, material):
        m = super()._material(material)
        level = m
        while isinstance(level, (FiberReinforced, FiberFamily)):  # fibers, possibly nested (FiberReinforced of ...)
            shape = np.shape(level.fibers)
            if len(shape) == 3:
                raise ParameterError("material", "material has per-quadrature-point fibers of shape "
                                     f"{shape}; the P1 path has one point per element: give fibers shaped "
                                     f"({self.dim}, n_elements) (e.g. the normalised average over the points) or "
                                     f"({self.dim},)")
            if len(shape) == 2 and shape[1] != self.n_elements:
                raise ParameterError("material", f"material has per-element fibers of shape {shape}, but the "
                                     f"mesh has {self.n_elements} elements: expected ({self.dim}, {self.n_elements})")
            level = level.base if isinstance(level, FiberReinforced) else None
        return m

    def _residual_from_F(self, m, F) -> np.ndarray:
        P = np.broadcast_to(m.stress(F), (self.dim, self.dim, self.n_elements))
        r_loc = np.einsum("ije,aje->aie", P, self._GA)  # (d + 1, d, nel): row d a + i
        return np.bincount(self._dofs_flat, weights=r_loc.reshape(-1), minlength=self.n_dofs)

    def _tangent_from_F(self, m, F):
        A = np.broadcast_to(m.tangent(F), (self.dim,) * 4 + (self.n_elements,))
        K_loc = np.einsum("ijkle,aje,ble->aibke", A, self._GA, self._G)  # rows d a + i, cols d b + k
        data = np.bincount(self._scatter, weights=K_loc.reshape(-1), minlength=self.nnz)
        return self.csr(data)

    def energy(self, u, material=None) -> float:
        """Stored energy ``sum_e A_e Psi(F_e)`` (NaN if the material is NaN somewhere, e.g. log J at J <= 0)."""
        psi = self._material(material).energy(self.deformation_gradient(u))
        return dot(self.areas, np.broadcast_to(psi, (self.n_elements,)))

    def residual(self, u, material=None) -> np.ndarray:
        """Internal force vector ``(n_dofs,)``, the gradient of :meth:`energy`."""
        return self._residual_from_F(self._material(material), self.deformation_gradient(u))

    def tangent(self, u, material=None) -> sp.csr_matrix:
        """Tangent stiffness (the Hessian of :meth:`energy`) as CSR with the fixed pattern."""
        return self._tangent_from_F(self._material(material), self.deformation_gradient(u))

    def residual_and_tangent(self, u, material=None):
        """``(residual(u), tangent(u))`` from one evaluation of ``F``."""
        m, F = self._material(material), self.deformation_gradient(u)
        return self._residual_from_F(m, F), self._tangent_from_F(m, F)

    def mass(self, density, lumped: bool = True) -> np.ndarray:
        """The mass matrix ``M_(a,i)(b,k) = int rho0 N_a N_b d_ik dX`` as data on this pattern: per element
        ``rho0 A_e (1 + d_ab) / 12``, lumped ``rho0 A_e / 3`` per vertex (the row sum), ``A_e`` the material area; on
        tetrahedra ``rho0 V_e (1 + d_ab) / 20`` and ``rho0 V_e / 4``."""
        rho = check_density(density)
        data = np.zeros(self.nnz)
        nv, dim = self.dim + 1, self.dim  # vertices per element, dimension
        if lumped:
            node_mass = np.bincount(self.t.ravel(), weights=np.tile(rho * self.areas / float(nv), nv),
                                    minlength=self.n_nodes)
            data[self.diagonal] = np.repeat(node_mass, dim)
            return data
        local = (np.ones((nv, nv)) + np.eye(nv)) / float((dim + 1) * (dim + 2))  # int N_a N_b / A (12 or 20)
        M_loc = np.einsum("ab,ik,e->aibke", local, np.eye(dim), rho * self.areas)
        return np.bincount(self._scatter, weights=M_loc.reshape(-1), minlength=self.nnz)

    def body_force(self, b) -> np.ndarray:
        """``f_(a,i) = int N_a b_i dX`` for a constant body force ``b`` (force per unit reference area or volume)."""
        b = check_vector("body_force", b, self.dim)
        nv = self.dim + 1
        share = np.bincount(self.t.ravel(), weights=np.tile(self.areas / float(nv), nv), minlength=self.n_nodes)
        return (share[:, None] * b[None, :]).ravel()


def _block_pattern(t, n_nodes: int, dim: int):
    """``(indptr, indices, scatter)``: the fixed CSR pattern (read-only) of elements whose local node ``a`` (row
    ``a`` of ``t``) has the dofs ``d t[a] ... d t[a] + d - 1``, and the data slot of each local entry
    ``(d a + i, d b + k)``, flat in the order ``[a, i, b, k, e]``. It is the node-adjacency pattern in ``d x d``
    blocks (``np.unique`` sorts the node pairs of each element): dof row ``d p + i`` starts at
    ``d^2 nptr[p] + d i deg(p)``, and node column ``r`` of row ``p`` holds dof columns ``d r ... d r + d - 1``."""
    nv, nel = t.shape
    nn, n = n_nodes, dim * n_nodes
    keys, slot = np.unique((t[:, None, :] * nn + t[None, :, :]).ravel(), return_inverse=True)  # node pairs (a, b, e)
    deg = np.bincount(keys // nn, minlength=nn)
    nptr = np.concatenate([[0], np.cumsum(deg)])
    nnz = dim * dim * keys.size
    index_dtype = np.int32 if max(nnz, n) < np.iinfo(np.int32).max else np.int64
    row_start = dim * dim * nptr[:-1, None] + dim * np.arange(dim) * deg[:, None]  # (nn, d): of dof row d p + i
    r = np.arange(dim)

    def position(pair, p, i, k):  # in the CSR data of the entry (d p + i, d q + k), (p, q) = the pair of keys[pair]
        return row_start[p, i] + dim * (pair - nptr[p]) + k
    indptr = np.append(row_start.ravel(), nnz).astype(index_dtype)
    indices = np.empty(nnz, dtype=index_dtype)
    pair = np.arange(keys.size)[:, None, None]
    indices[position(pair, keys[pair] // nn, r[:, None], r)] = dim * (keys[pair] % nn) + r
    indices.setflags(write=False)
    indptr.setflags(write=False)
    scatter = position(slot.reshape(nv, 1, nv, 1, nel), t[:, None, None, None, :], r[:, None, None, None], r[:, None])
    return indptr, indices, scatter.reshape(-1).astype(np.intp)


def element_geometry(p, t):
    """``(t, flipped, measures, G)`` of P1 triangles or tetrahedra (``p`` ``(d, n)``, ``t`` ``(d + 1, m)``): ``t``
    positively oriented (a copy, the last two vertices of the elements ``flipped`` swapped), the areas (volumes)
    ``|det J| / d!`` and the shape-function gradients ``G[a, j, e] = dN_a/dX_j``. With ``J = [d1 .. dd]``, the edges
    from vertex 0, rows ``1 .. d`` of ``G`` are the rows of ``J^-1``: cofactors over ``det J``, ``(d2_y, -d2_x)`` and
    ``(-d1_y, d1_x)`` in 2D, ``d_c+1 x d_c+2`` (indices mod 3) in 3D; ``G[0] = -(G[1] + .. + G[d])``, as the ``N_a``
    sum to one. Swapping two vertices swaps their rows and changes the sign of ``det J``, exactly."""
    dim = p.shape[0]
    x = p[:, t]  # (d, d + 1, m)
    d = np.stack([x[:, c] - x[:, 0] for c in range(1, dim + 1)], axis=1)  # d[i, c]: the edge from vertex 0 to c + 1
    if dim == 2:
        cofactors = np.stack([np.stack([d[1, 1], -d[0, 1]]), np.stack([-d[1, 0], d[0, 0]])])
    else:
        cofactors = np.stack([np.cross(d[:, (c + 1) % 3], d[:, (c + 2) % 3], axis=0) for c in range(3)])
    det = np.einsum("ie,ie->e", d[:, 0], cofactors[0])
    G = np.empty((dim + 1, dim, t.shape[1]))
    G[1:] = cofactors / det
    flipped = np.flatnonzero(det < 0)
    if flipped.size:  # swap the last two vertices, and their rows of G
        t = t.copy()
        t[-2:, flipped] = t[:-3:-1, flipped]
        G[-2:, :, flipped] = G[:-3:-1, :, flipped]
    G[0] = -G[1]
    for row in G[2:]:
        G[0] -= row
    return t, flipped, np.abs(det) / (2.0 if dim == 2 else 6.0), G


def _mesh_arrays(mesh):
    """``(p, t)`` of a straight-sided scikit-fem triangle or tetrahedron mesh, checked by
    :func:`~tissuefem.engine.meshes.check_mesh` with ``cut=True``."""
    if not (hasattr(mesh, "p") and hasattr(mesh, "t")):
        raise ParameterError("mesh", f"mesh must be a scikit-fem MeshTri or MeshTet (with p and t), got "
                                     f"{type(mesh).__name__}")
    if getattr(mesh, "affine", True) is False:
        raise ParameterError("mesh", "mesh must be a straight-sided linear (P1) triangle or tetrahedron mesh, got a "
                                     "curved/high-order mesh")
    return check_mesh(mesh.p, mesh.t, cut=True)


def vector_basis(mesh, order: int = 1, intorder: int | None = None) -> Basis:
    """scikit-fem's ``Basis(mesh, ElementVector(ElementTriP<order>()), intorder)`` (``ElementTetP<order>`` on
    tetrahedra; default degree ``2 order``): node ``a`` has dofs ``d a ... d a + d - 1``, then come the P2 edge
    midpoints, every assembler's layout."""
    if order not in (1, 2):
        raise ParameterError("order", f"order must be 1 or 2, got {order!r}")
    intorder = check_count("intorder", 2 * order if intorder is None else intorder, 1, 19)
    elements = (ElementTetP1, ElementTetP2) if np.shape(mesh.p)[0] == 3 else (ElementTriP1, ElementTriP2)
    return Basis(mesh, ElementVector(elements[order - 1]()), intorder=intorder)


class QuadratureAssembler(_FixedPattern):
    """:class:`P1Assembler`'s sums at every quadrature point (``A_e`` replaced by the weights ``dx``), into a pattern
    computed once: this makes P2 affordable. ``basis``: a :func:`vector_basis` (local function ``2 a + i`` is
    ``N_a e_i``); ``material`` and ``weights`` as :class:`P1Assembler`'s."""

    def __init__(self, basis, material=None, weights=None):
        if not isinstance(getattr(basis, "elem", None), ElementVector):
            raise ParameterError("basis", f"basis must be a scikit-fem Basis with an ElementVector element, got "
                                          f"{basis!r}")
        p, _ = _mesh_arrays(basis.mesh)
        self.basis, self.material = basis, material
        self.dim = dim = p.shape[0]
        nloc = len(basis.basis) // dim
        self.n_elements = basis.mesh.nelements
        # grad N_a and N_a: component 0 of the vector function N_a e_0
        self._G = np.array([basis.basis[dim * a][0].grad[0] for a in range(nloc)])  # (nloc, d, nel, nq)
        self._N = np.array([np.asarray(basis.basis[dim * a][0])[0] for a in range(nloc)])  # (nloc, nel, nq)
        self._dx = basis.dx if weights is None else basis.dx * check_weights(weights, self.n_elements)[:, None]
        self._GW = self._G * self._dx
        dofs = np.asarray(basis.element_dofs, dtype=np.int64)  # (d nloc, nel), row d a + i: d N_a + i
        self._set_pattern(dofs[::dim] // dim, basis.N // dim)
        if not np.array_equal(dofs, self.element_dofs):
            raise ParameterError("basis", "basis must number its dofs node by node, as vector_basis does")

    def energy(self, u, material=None) -> float:
        """``sum Psi(F) dx`` (NaN where the material is, e.g. the log model at ``J <= 0``)."""
        return float(np.sum(self._material(material).energy(self.deformation_gradient(u)) * self._dx))

    def residual(self, u, material=None) -> np.ndarray:
        """The internal force vector, the gradient of :meth:`energy`."""
        P = self._material(material).stress(self.deformation_gradient(u))
        r = np.einsum("ijeq,ajeq->aie", P, self._GW)
        return np.bincount(self._dofs_flat, weights=r.reshape(-1), minlength=self.n_dofs)

    def tangent(self, u, material=None) -> sp.csr_matrix:
        """The tangent stiffness (Hessian of :meth:`energy`) on the fixed pattern."""
        A = self._material(material).tangent(self.deformation_gradient(u))
        AG = np.einsum("ijkleq,ajeq->aikleq", A, self._GW)
        K = np.einsum("aikleq,bleq->aibke", AG, self._G)
        return self.csr(np.bincount(self._scatter, weights=K.reshape(-1), minlength=self.nnz))

    def mass(self, density, lumped: bool = False) -> np.ndarray:
        """The mass matrix ``int rho0 N_a N_b d_ik dX`` as data on this pattern (``lumped``: row sums, refused where
        some dof would get no mass, as the vertices of P2 triangles do)."""
        rho = check_density(density)
        NN = np.einsum("aeq,beq,eq->abe", self._N, self._N, rho * self._dx)
        M_loc = np.einsum("abe,ik->aibke", NN, np.eye(self.dim))
        data = np.bincount(self._scatter, weights=M_loc.reshape(-1), minlength=self.nnz)
        if not lumped:
            return data
        rows = self.csr(data).sum(axis=1).A.ravel()
        if not np.all(rows > 1e-8 * np.mean(np.abs(rows))):
            raise ParameterError("mass", "mass='lumped': row-sum lumping gives some dofs zero or negative mass with "
                                         "this element (P2 triangles' vertices get none); use mass='consistent'")
        lumped_data = np.zeros(self.nnz)
        lumped_data[self.diagonal] = rows
        return lumped_data

    def body_force(self, b) -> np.ndarray:
        """``f_(a,i) = int N_a b_i dX`` for a constant body force ``b``."""
        b = check_vector("body_force", b, self.dim)
        share = np.einsum("aeq,eq->ae", self._N, self._dx)  # (nloc, nel)
        f = np.einsum("ae,i->aie", share, b)
        return np.bincount(self._dofs_flat, weights=f.reshape(-1), minlength=self.n_dofs)


class FormsAssembler(QuadratureAssembler):
    """Energy, residual and tangent by the readable forms of :mod:`tissuefem.engine.forms`, on
    :class:`QuadratureAssembler`'s pattern: the reference the fast assemblers are tested against. The forms
    integrate whole elements, so element ``weights`` (a cut's partial elements) are refused."""

    def __init__(self, basis, material=None, weights=None):
        if weights is not None:
            raise ParameterError("weights", "weights: the forms path integrates whole elements; weighted (cut) "
                                            "elements need assembly='fast'")
        super().__init__(basis, material)

    def energy(self, u, material=None) -> float:
        return float(asm(energy_form(self._material(material)), self.basis, u=self.basis.interpolate(u)))

    def residual(self, u, material=None) -> np.ndarray:
        return asm(residual_form(self._material(material)), self.basis, u=self.basis.interpolate(u))

    def tangent(self, u, material=None) -> sp.csr_matrix:
        K = asm(tangent_form(self._material(material)), self.basis, u=self.basis.interpolate(u)).tocsr()
        K.sum_duplicates()
        if K.nnz == self.nnz and np.array_equal(K.indptr, self.indptr) and np.array_equal(K.indices, self.indices):
            return self.csr(K.data)
        rows = np.repeat(np.arange(self.n_dofs), np.diff(self.indptr))
        return self.csr(np.asarray(K[rows, self.indices]).ravel())


def make_assembler(mesh, *, order: int = 1, intorder: int | None = None, assembly: str = "fast", weights=None):
    """``(basis, assembler)``: :class:`P1Assembler` (P1) or :class:`QuadratureAssembler` (P2) for ``assembly="fast"``,
    :class:`FormsAssembler` (the readable reference, slow) for ``"forms"``."""
    if not isinstance(assembly, str) or assembly not in ("fast", "forms"):
        raise ParameterError("assembly", f"assembly must be 'fast' or 'forms', got {assembly!r}")
    _mesh_arrays(mesh)
    basis = vector_basis(mesh, order, intorder)
    if assembly == "forms":
        return basis, FormsAssembler(basis, weights=weights)
    if order == 1:
        return basis, P1Assembler(mesh, weights=weights)
    return basis, QuadratureAssembler(basis, weights=weights)
