"""The model: a body, exactly the terms acting on it, and the handles that hold it.

A :class:`Model` is a mesh with a P1 or P2 displacement basis, a material and a list of terms
(:mod:`.terms`, made by :mod:`.effects`); its potential is their sum,

    E(u) = W(u) [+ fibres] [+ probe] [+ sutures] [+ contact] [- f . u] [+ 1/(2 dt^2) |u - u~|_M^2].

:mod:`.stepping` minimises it; :meth:`Model.remapped` carries it across a cut or an excision. A
:class:`Handle` is a constraint, not a term: it holds a region at prescribed displacements (checked where they
enter). Every Hessian goes into one fixed sparsity pattern (:class:`Pattern`), widened where a term couples
dofs the mesh does not (sutures) and rebuilt when a term's couplings change (self-contact's ``covers``).
"""

from __future__ import annotations

import itertools

import numpy as np
import scipy.sparse as sp
from scipy.sparse import csgraph

from .assembly import make_assembler
from .constants import TISSUE_DENSITY
from .contact import Contact
from .effects import as_terms, keyword_terms
from .materials import det, vector_length
from .meshes import index_list
from .parameters import (REACH, ParameterError, call_user, check_bounded_vector, check_count, check_density,
                         check_indices, check_list, check_real, check_real_array, check_vector, is_sequence)
from .terms import (Elastic, ElementTerm, GhostPenalty, Inertia, Load, Probe, SummedDensity, Sutures, Term,
                    boundary_lengths, extent, surface_lengths)

__all__ = ["Model", "Handle", "Pattern", "region_nodes"]


# ------------------------------------------------------------------------------------------------ regions

def _selected(field, mask, points) -> np.ndarray:
    """The indices of the points ``(2, n)`` a user's ``mask(points) -> bools`` selects (given a copy)."""
    on = np.asarray(call_user(field, "mask", mask, points.copy()))
    if on.dtype.kind not in "biu":  # bools (or 0/1 integers), never floats, strings or objects cast to bool
        raise ParameterError(field, f"{field}: the mask must return bools, got dtype {on.dtype}")
    if on.shape != points.shape[1:]:
        raise ParameterError(field, f"{field}: the mask must return one bool per point, shape "
                                    f"({points.shape[1]},), got {on.shape}")
    return np.flatnonzero(on)


def region_nodes(mesh, region, field: str = "region") -> np.ndarray:
    """The mesh nodes (sorted indices) a region selects, ``ValueError`` naming ``field`` if none: a boundary
    name (``"left"``), a ``mask(X) -> bool`` on the reference coordinates ``(d, n_nodes)``, a box
    ``{"box": [x0, y0, x1, y1]}``, a disc ``{"near": [x, y], "radius": r}``, ``{"nodes": [...]}``, indices. On a
    tetrahedron mesh a box is ``[x0, y0, z0, x1, y1, z1]`` and a ball ``{"near": [x, y, z], "radius": r}``."""
    p = np.asarray(mesh.p, dtype=float)
    dim, n = p.shape
    if isinstance(region, str):
        if mesh.boundaries is None or region not in mesh.boundaries:
            names = sorted(mesh.boundaries) if mesh.boundaries else []
            raise ValueError(f"{field}: {region!r} is not a boundary of the mesh; boundaries: {names}")
        nodes = np.unique(mesh.facets[:, mesh.boundaries[region]])
    elif callable(region):
        nodes = _selected(field, region, p)
    elif isinstance(region, dict) and "box" in region:
        box = region["box"]
        if not is_sequence(box) or len(box) != 2 * dim:
            corners = "[x0, y0, x1, y1]" if dim == 2 else "[x0, y0, z0, x1, y1, z1]"
            raise ParameterError(f"{field}.box", f"{field}.box must be {corners}, got {box!r:.200}")
        bounds = np.array([check_real(f"{field}.box[{i}]", b) for i, b in enumerate(box)])[:, None]
        tol = 1e-9 * max(1.0, float(np.ptp(p)))
        inside = (p >= bounds[:dim] - tol) & (p <= bounds[dim:] + tol)
        nodes = np.flatnonzero(inside.all(axis=0))
    elif isinstance(region, dict) and "near" in region:
        if "radius" not in region:
            raise ValueError(f"{field}: a disc {{'near': [x, y], 'radius': r}} needs its radius")
        centre = check_bounded_vector(f"{field}.near", region["near"], np.inf, dim)
        radius = check_real(f"{field}.radius", region["radius"], 0.0, None)
        nodes = np.flatnonzero(vector_length(p - centre[:, None]) <= radius * (1 + 1e-9))
    else:
        raw = region["nodes"] if isinstance(region, dict) and "nodes" in region else region
        if isinstance(raw, dict):
            raise ParameterError(field, f"{field}: a region is a boundary name, a mask, a box, a disc or "
                                        f"node indices; got {region!r:.200}")
        nodes = np.unique(check_indices(field, raw, n, "node indices"))
    if nodes.size == 0:
        lo, hi = p.min(axis=1), p.max(axis=1)
        spans = ", ".join(f"{c} {lo[i]:g}..{hi[i]:g}" for i, c in enumerate("xyz"[:dim]))
        raise ValueError(f"{field}: selects no node of the mesh (it lies outside the domain, which spans {spans})")
    return nodes.astype(np.intp)


# ------------------------------------------------------------------------------------------------ handles

def _map_positions(target, points, field) -> np.ndarray:
    """``target(points)`` checked: finite real values shaped like ``points``, else a ``ValueError`` naming ``field``."""
    x = check_real_array(field, call_user(field, "map", target, points.copy()))  # a copy: the points stay put
    if x.shape != points.shape:
        raise ParameterError(field, f"{field}: the map returned shape {x.shape}, expected {points.shape}")
    if not np.all(np.isfinite(x)):
        raise ParameterError(field, f"{field}: the map returned non-finite positions")
    return x


def _check_target(target, points=None, field="target", reach=None):
    """A checked target: a finite translation ``(d,)`` (``d`` the points' dimension; without points 2 or 3) or a map
    finite at ``points``; with ``reach`` (``REACH`` domain sizes) its displacement may not exceed it in any
    component."""
    if callable(target):
        if points is not None:
            x = _map_positions(target, points, field)
            if reach is not None and np.any(np.abs(x - points) > reach):
                raise ValueError(f"{field}: the map moves points by more than {REACH:g} domain sizes ({reach:g})")
        return target
    size = points.shape[0] if points is not None else 3 if is_sequence(target) and len(target) == 3 else 2
    try:
        t = check_vector(field, target, size)
    except ParameterError:
        xy = "(dx, dy)" if size == 2 else "(dx, dy, dz)"
        raise ParameterError(field, f"{field} must be a translation {xy} of finite real numbers, "
                                    f"shape ({size},), or a callable, got {target!r:.100}") from None
    if reach is not None and np.any(np.abs(t) > reach):
        raise ValueError(f"{field} = {t.tolist()}: a displacement larger than {REACH:g} domain sizes ({reach:g})")
    return t


class Handle:
    """Material points held at prescribed positions (a fixed edge, a pulled edge, a user's grab).

    ``region``: anything :func:`region_nodes` takes. ``target``: a translation ``(dx, dy)`` (``(dx, dy, dz)`` on
    tetrahedra, its size checked when a model takes the handle; default: fixed) or a map ``phi(X) -> x``, ``(d, n)
    -> (d, n)``. ``base`` (a grab, of node indices): the nodes' displacement ``(d, n_nodes)`` when grabbed; they are
    held at ``base + (phi(X) - X)``. ``name``: to find it by (else the model names it); ``anchor``: the point
    grabbed (a drag moves it by the mouse's offset).
    """

    def __init__(self, region, target=None, *, base=None, name=None, anchor=None):
        if not (isinstance(region, (str, dict)) or callable(region)):
            arr = np.asarray(region)
            if arr.ndim != 1 or arr.size == 0 or not np.issubdtype(arr.dtype, np.integer) or arr.min() < 0:
                raise ValueError(f"region must be a boundary name, a mask, a box, a disc or node indices, "
                                 f"got {region!r}")
            region = np.unique(arr).astype(np.intp)
        if name is not None and not isinstance(name, str):
            raise ValueError(f"name must be a string (or None: the model names the handle), got {name!r}")
        self.region, self.name = region, name
        self.anchor = None if anchor is None else check_vector(
            "anchor", anchor, 3 if is_sequence(anchor) and len(anchor) == 3 else 2)
        if base is not None and (isinstance(region, (str, dict)) or callable(region)):
            raise ValueError("base: a handle with a base displacement must be given node indices as its region")
        self.base = None if base is None else np.asarray(base, dtype=float)  # its shape checked by the model
        self.nodes = None  # set when a model takes the handle
        self._points = None  # reference positions of its dofs' points (2, n), set by the model
        self._reach = None  # the largest displacement a target may prescribe, set by the model
        # None: held where it is (zeros of the mesh's dimension when a model takes it)
        self.target = None if target is None else _check_target(target)

    def move(self, target) -> None:
        """Set a new target (a translation or a map): user input enters here, checked; a refusal keeps the old."""
        self.target = _check_target(target, self._points, f"handle {self.name!r} target", self._reach)

    def remap(self, parent, material=None) -> "Handle | None":
        """The same handle on a mesh whose node ``i`` comes from old node ``parent[i]`` (a cut or an excision): every
        copy of a held node that has material at its place (``material[i]``, bools; ``None``: all have) is held, with
        its parent's base displacement; ``None`` if none survives. A virtual node (a copy in cut elements none of
        which has material at that corner) holds nothing: the piece it belongs to was cut free of the handle."""
        if self.nodes is None:
            raise ValueError("remap: the handle is not part of a model yet")
        parent = np.asarray(parent, dtype=np.intp)
        at = np.minimum(np.searchsorted(self.nodes, parent), self.nodes.size - 1)  # (the nodes are sorted)
        index = np.where(self.nodes[at] == parent, at, -1)  # each new node's held parent in self.nodes, or -1
        if material is not None:
            material = np.asarray(material)
            if material.dtype != bool or material.shape != parent.shape:
                raise ParameterError("material", f"material must be one bool per new node, shape {parent.shape}, "
                                                 f"got dtype {material.dtype} and shape {material.shape}")
            index = np.where(material, index, -1)
        new_nodes = np.flatnonzero(index >= 0)
        if new_nodes.size == 0:
            return None
        base = None if self.base is None else self.base[:, index[new_nodes]]
        h = Handle(new_nodes, base=base, name=self.name, anchor=self.anchor)
        h.target, h._reach = self.target, self._reach
        h.nodes = new_nodes  # its region is these nodes: known before any model takes it
        return h

    def __repr__(self):
        where = f"{self.nodes.size} nodes" if self.nodes is not None else repr(self.region)
        return f"Handle({where}, target={self.target!r}, name={self.name!r})"


# ------------------------------------------------------------------------------------------------ the pattern

class Pattern:
    """The model's fixed CSR sparsity pattern: the assembler's, widened by the terms' couplings. ``base_positions``
    maps the assembler's entries into it (``None``: the same); ``node_block[i, j, a]`` is the position of the entry
    (``d a + i``, ``d a + j``) of vertex ``a``'s diagonal block (``d`` the mesh's dimension)."""

    def __init__(self, assembler, n_vertices, couplings=()):
        n = self.n = assembler.n_dofs
        base_keys = np.repeat(np.arange(n, dtype=np.int64), np.diff(assembler.indptr)) * n + assembler.indices
        new = np.zeros(0, dtype=np.int64)
        if couplings:  # (the assemblers' patterns are sorted)
            new = np.unique(np.concatenate([np.asarray(r, dtype=np.int64) * n + np.asarray(c, dtype=np.int64)
                                            for r, c in couplings]))
            at = np.minimum(np.searchsorted(base_keys, new), base_keys.size - 1)
            new = new[base_keys[at] != new]  # only the couplings the mesh does not have already
        if new.size == 0:
            self.indptr, self.indices = assembler.indptr, assembler.indices
            self._keys = base_keys
            self.base_positions = None
        else:
            # merge the few new keys into the sorted base keys: rebuilt whenever contact pairs change, a
            # widening must cost a merge, not a sort of everything
            inserted = np.searchsorted(base_keys, new)
            keys = np.insert(base_keys, inserted, new)
            counts = np.bincount(keys // n, minlength=n)
            # the assembler's index type (scipy would copy wider indices into a writable array, and the linear
            # solver condenses only a read-only pattern by its precomputed gather)
            index_dtype = np.int32 if max(keys.size, n) < np.iinfo(np.int32).max else np.int64
            self.indptr = np.concatenate([[0], np.cumsum(counts)]).astype(index_dtype)
            self.indices = (keys % n).astype(index_dtype)
            self.indptr.setflags(write=False)
            self.indices.setflags(write=False)
            self._keys = keys
            # a base entry moves up by the number of new keys inserted at or before it
            shift = np.cumsum(np.bincount(inserted, minlength=base_keys.size + 1))[: base_keys.size]
            self.base_positions = np.arange(base_keys.size) + shift
        self.nnz = self._keys.size
        nodes, d = np.arange(n_vertices, dtype=np.int64), getattr(assembler, "dim", 2)
        i, j = np.indices((d, d))[..., None]
        self.node_block = self.positions(d * nodes + i, d * nodes + j)

    def positions(self, rows, cols) -> np.ndarray:
        """Positions in the data array of the entries ``(rows, cols)`` (which must be in the pattern)."""
        keys = np.asarray(rows, dtype=np.int64) * self.n + np.asarray(cols, dtype=np.int64)
        pos = np.searchsorted(self._keys, keys)
        if np.any(pos >= self.nnz) or np.any(self._keys[np.minimum(pos, self.nnz - 1)] != keys):
            raise ValueError("entries outside the model's sparsity pattern")
        return pos.astype(np.intp)

    def add_base(self, data, base_data) -> None:
        """``data += base_data`` for data on the assembler's own pattern."""
        if self.base_positions is None:
            data += base_data
        else:
            data[self.base_positions] += base_data

    def zeros(self) -> np.ndarray:
        return np.zeros(self.nnz)

    def csr(self, data) -> sp.csr_matrix:
        K = sp.csr_matrix((data, self.indices, self.indptr), shape=(self.n, self.n), copy=False)
        K.has_sorted_indices = True
        K.has_canonical_format = True
        return K


# ------------------------------------------------------------------------------------------------ the model

def _check_material_at_rest(assembler, material) -> None:
    """The material answers for the model's own ``F`` at rest with finite arrays of the right shapes, so that a
    wrong object is refused where it enters rather than in the middle of a step."""
    F = assembler.deformation_gradient(np.zeros(assembler.n_dofs))
    rest = F.shape[2:]
    expected = {"energy": rest, "stress": F.shape, "tangent": F.shape[:2] + F.shape}
    for method, shape in expected.items():
        with np.errstate(all="ignore"):
            value = np.asarray(call_user("material", f"{method}(F) at rest", getattr(material, method), F))
        try:
            fits = np.broadcast_shapes(value.shape, shape) == shape
        except ValueError:
            fits = False
        if value.dtype.kind not in "iuf" or not fits or not np.all(np.isfinite(value)):
            raise ValueError(f"material: {method}(F) at rest must be finite real values shaped {shape}, got "
                             f"dtype {value.dtype} shape {value.shape}")


def _overrides(term, hook) -> bool:
    return getattr(type(term), hook) is not getattr(Term, hook)


class Holding:
    """The handles of a :class:`Model`, resolved to nodes and dofs when taken; :meth:`prescribed` gives the
    stepper the held dofs and their displacements."""

    def _handle_dofs(self, h: Handle, nodes) -> tuple[np.ndarray, np.ndarray]:
        """The dofs a handle holding ``nodes`` holds, and each dof's node's index in ``nodes`` (-1: P2 edge dofs)."""
        dofs = [self.basis.nodal_dofs[:, nodes].ravel()]
        owner = [np.tile(np.arange(nodes.size), self.dim)]
        if self.order == 2:  # P2: the mid-edge dofs of the held edges (the facets of triangles)
            mesh, basis = self.mesh, self.basis
            ends, mid_dofs = (mesh.facets, basis.facet_dofs) if self.dim == 2 else (mesh.edges, basis.edge_dofs)
            if self.dim == 2 and isinstance(h.region, str):
                edges = np.asarray(mesh.boundaries[h.region])
            elif self.dim == 2 and callable(h.region):
                mid = 0.5 * (self.X[:, ends[0]] + self.X[:, ends[1]])
                edges = _selected(f"handle {h.name!r} region", h.region, mid)
            else:  # the edges whose ends are both held
                held = np.zeros(mesh.nvertices, dtype=bool)
                held[nodes] = True
                edges = np.flatnonzero(held[ends[0]] & held[ends[1]])
            dofs.append(mid_dofs[:, edges].ravel())
            owner.append(np.full(self.dim * edges.size, -1))
        return np.concatenate(dofs), np.concatenate(owner)

    def add_handle(self, handle: Handle) -> Handle:
        """Take a handle: resolve its region to nodes and dofs (a name is given if it has none)."""
        if not isinstance(handle, Handle):
            raise ValueError(f"handles must be Handle objects, got {handle!r}")
        field = f"handle {handle.name!r} region" if handle.name else "handle region"
        nodes = region_nodes(self.mesh, handle.region, field)
        base = handle.base
        if base is not None and (base.shape != (self.dim, nodes.size) or not np.all(np.isfinite(base))):
            raise ValueError(f"handle {handle.name!r}: base must be finite and shaped ({self.dim}, {nodes.size}) (the "
                             f"mesh's dimension, one column per node), got shape {base.shape}")
        if base is not None and self.order != 1:
            raise ValueError("handles with a base displacement (grabs) need order=1")
        names = {h.name for h in self.handles}
        name = handle.name
        if name is None:
            name = next(f"handle{k}" for k in itertools.count(len(self.handles)) if f"handle{k}" not in names)
        elif name in names:
            raise ValueError(f"a handle named {name!r} exists already")
        # everything is checked before the handle is touched: a refused handle is left as it was given
        dofs, owner = self._handle_dofs(handle, nodes)
        points = self.dof_points[:, dofs]
        reach = REACH * self.size
        target = np.zeros(self.dim) if handle.target is None else handle.target
        _check_target(target, points, f"handle {name!r} target", reach)
        if handle.anchor is not None and handle.anchor.size != self.dim:
            raise ParameterError("anchor", f"handle {name!r}: anchor must have {self.dim} coordinates (the mesh's "
                                           f"dimension), got {handle.anchor.size}")
        handle.target = target
        handle.name, handle.nodes, handle._reach = name, nodes, reach
        handle._points, handle._dofs, handle._owner = points, dofs, owner
        self.handles.append(handle)
        return handle

    def remove_handle(self, name) -> Handle:
        """Let go of the handle ``name`` (its nodes are free from the next step on)."""
        h = self.handle(name)
        self.handles.remove(h)
        return h

    def handle(self, name) -> Handle:
        """The handle called ``name`` (or at index ``name``)."""
        if isinstance(name, (int, np.integer)) and not isinstance(name, (bool, np.bool_)):
            if 0 <= name < len(self.handles):
                return self.handles[name]
            raise ValueError(f"no handle at index {name}; there are {len(self.handles)}")
        found = [h for h in self.handles if isinstance(name, str) and h.name == name]  # names are strings
        if found:
            return found[0]
        raise ValueError(f"no handle named {name!r:.100}; handles: {[h.name for h in self.handles]}")

    def set_targets(self, targets) -> None:
        """Move several handles at once, all or nothing: ``None``, one target per handle (``None`` leaves one
        where it is) or ``{name or index: target}``; a refusal leaves all of them as they were."""
        if targets is None:
            return
        if isinstance(targets, dict):
            items = list(targets.items())
        else:
            seq = check_list("targets", targets, "targets, one per handle (or a dict, or None)")
            if len(seq) != len(self.handles):
                raise ValueError(f"targets has {len(seq)} entries but the model has {len(self.handles)} handles")
            items = list(enumerate(seq))
        checked = []
        for key, target in items:
            try:  # (a bool is neither a name nor an index)
                h = self.handle(key)
            except ValueError as err:
                raise ValueError(f"targets: {err}") from None
            if target is not None:
                checked.append((h, _check_target(target, h._points, f"targets[{key!r}]", h._reach)))
        for h, target in checked:
            h.target = target

    def prescribed(self) -> tuple[np.ndarray, np.ndarray]:
        """The held dofs (sorted) and their displacements; where handles overlap, the later one wins."""
        if not self.handles:
            return np.zeros(0, dtype=np.intp), np.zeros(0)
        all_values = []
        for h in self.handles:
            x = _map_positions(h.target, h._points, f"handle {h.name!r} target") if callable(h.target) else \
                h._points + h.target[:, None]
            values = (x - h._points)[self.component[h._dofs], np.arange(h._dofs.size)]
            if h.base is not None:  # a grab: its nodes' displacement when grabbed, plus the target's offset
                held = h.base[self.component[h._dofs], np.maximum(h._owner, 0)]
                values = values + np.where(h._owner >= 0, held, 0.0)
            all_values.append(values)
        dofs, values = np.concatenate([h._dofs for h in self.handles]), np.concatenate(all_values)
        unique, first_in_reversed = np.unique(dofs[::-1], return_index=True)
        return unique.astype(np.intp), values[::-1][first_in_reversed]

    def reaction(self, u, handle) -> np.ndarray:
        """The resultant force ``(f1, f2)`` (``(f1, f2, f3)`` in 3D) the handle exerts on the body at ``u`` (at
        equilibrium, what a haptic device would render): the sum of ``f_int - f_ext`` over the handle's dofs, per
        component."""
        h = handle if isinstance(handle, Handle) else self.handle(handle)
        q = self.internal_force(u) - self.external
        dofs = np.unique(h._dofs)
        return np.array([q[dofs[self.component[dofs] == i]].sum() for i in range(self.dim)])


class Model(Holding):
    """A hyperelastic body (mesh, displacement basis, material) and exactly the terms acting on it.

    ``mesh``: a ``skfem.MeshTri`` of straight triangles (degenerate or folded ones are refused) or a
    ``skfem.MeshTet`` (3D: every term but self-contact, which refuses it, as do cuts); ``material``:
    the :class:`~tissuefem.engine.terms.Elastic` term's (:mod:`.materials`, :mod:`.inversion`); ``order``: P1
    or P2, ``intorder``: the quadrature degree (default ``2 order``), ``assembly``: ``"fast"`` or ``"forms"``
    (the readable reference); ``terms``: more :class:`~tissuefem.engine.terms.Term` objects or factories
    ``model -> Term`` (:func:`.effects.factory`); ``handles``: :class:`Handle` objects; ``density``: ``rho0``
    per unit reference area; ``weights``: per-element material fractions (elements cut through).

    Shorthands for the common terms (:mod:`.effects`): ``dt`` (s) with ``mass`` ``"lumped"`` or
    ``"consistent"`` (backward Euler; without: quasistatic); ``gravity`` ``(gx, gy)`` (``(gx, gy, gz)`` in 3D);
    ``body_force`` ``(bx, by)`` per unit area (volume); ``tractions`` ``{boundary: (tx, ty)}`` per unit length
    (area); ``fibers`` ``(stiffness, directions)``; ``probes``: dicts ``center, radius, stiffness[, label,
    smoothing]``; ``sutures``: ``pairs, stiffness, gaps[, tightness, coefficients]``; ``contact``: ``distance,
    stiffness[, surface, skin]``.
    """

    def __init__(self, mesh, material, *, order: int = 1, intorder: int | None = None, assembly: str = "fast",
                 terms=(), handles=(), density=TISSUE_DENSITY, weights=None, dt=None, mass: str = "lumped",
                 gravity=None, body_force=None, tractions=None, fibers=None, probes=(), sutures=None, contact=None,
                 _meshmap=None):
        order = check_count("order", order, 1, 2)
        handles, terms = check_list("handles", handles, "Handle objects"), check_list("terms", terms, "terms")
        made = keyword_terms(dt=dt, mass=mass, gravity=gravity, body_force=body_force, tractions=tractions,
                             fibers=fibers, probes=probes, sutures=sutures, contact=contact)
        self.mesh, self.order, self.intorder, self.assembly, self.weights = mesh, order, intorder, assembly, weights
        if len(np.shape(getattr(mesh, "p", None))) != 2 or np.shape(mesh.p)[0] not in (2, 3):
            raise ParameterError("mesh", f"mesh must be a scikit-fem MeshTri or MeshTet, got {type(mesh).__name__}")
        self.dim = dim = mesh.p.shape[0]
        if dim == 3 and weights is not None:
            raise ParameterError("weights", "weights: cuts through elements are 2D only for now; the mesh has "
                                            "tetrahedra")
        self.basis, self.assembler = make_assembler(mesh, order=order, intorder=intorder, assembly=assembly,
                                                    weights=weights)
        self.n_dofs = n = self.basis.N
        if not np.array_equal(self.basis.nodal_dofs, np.arange(dim * mesh.nvertices).reshape(-1, dim).T):
            raise RuntimeError("unexpected dof numbering of the vector basis")
        self.X = np.asarray(mesh.p, dtype=float)
        self.middle, self.size = extent(self.X)  # the domain's centre and size L (what "reach" is measured in)
        self.density = check_density(density)
        self.material = material
        # which component each dof carries (the vector basis interleaves them, P2's mid-edge dofs too), and where
        self.component = np.arange(n, dtype=np.intp) % dim
        self.dof_points = np.asarray(self.basis.doflocs, dtype=float)
        self._meshmap, self._boundary_lengths = _meshmap, None  # a probe's surface weights, when first asked for
        elastic = Elastic(self.assembler, material)
        _check_material_at_rest(self.assembler, material)
        # the ghost penalty ties the thin pieces of a cut to their neighbours
        found = [elastic] + as_terms(GhostPenalty.of(mesh, weights, material) if order == 1 else None)
        for t in made + terms:
            found += as_terms(t(self) if callable(t) and not isinstance(t, Term) else t)  # (set_terms refuses the rest)
        self.terms = []
        self.set_terms(found)
        self.handles: list[Handle] = []
        for h in handles:
            self.add_handle(h)

    @property
    def boundary_lengths(self) -> np.ndarray:
        """A probe's surface weights: each node's share of the boundary's length (area on tetrahedra), after a
        topology change of the material's surface (:func:`~tissuefem.engine.terms.surface_lengths`)."""
        if self._boundary_lengths is None:
            m = self._meshmap
            self._boundary_lengths = boundary_lengths(self.mesh) if m is None else surface_lengths(m)
            self._meshmap = None  # not kept alive any longer
        return self._boundary_lengths

    # ------------------------------------------------------------------ terms and pattern
    def _build(self):
        couplings = [c for c in (t.couplings() for t in self.terms) if c is not None]
        self.pattern = Pattern(self.assembler, self.mesh.nvertices, couplings)
        for t in self.terms:
            t.bind(self.pattern)
        self._element_terms = [t for t in self.terms if isinstance(t, ElementTerm)]
        self._other_terms = [t for t in self.terms if not isinstance(t, ElementTerm)]
        densities = [t.density for t in self._element_terms]
        self._density = densities[0] if len(densities) == 1 else SummedDensity(densities)
        self._safe_density = SummedDensity(densities, safe=True)
        # the terms whose class overrides a hook (contact, see Term): a model without one pays nothing per iteration
        self._pattern_terms = [t for t in self._other_terms if _overrides(t, "covers")]
        self._limit_terms = [t for t in self._other_terms if _overrides(t, "max_step")]
        self._step_terms = [t for t in self._other_terms if _overrides(t, "begin_step") or _overrides(t, "end_step")]

    def set_terms(self, terms) -> None:
        """Take the list ``terms`` (sorted by rank, stably: the sums keep the order given), or keep the old one."""
        terms = list(terms)
        bad = [t for t in terms if not isinstance(t, Term)]
        if bad:
            raise ParameterError("terms", "terms must be Term objects (the constructor also takes factories "
                                          f"model -> Term), got {bad[0]!r:.200}")
        old, self.terms = self.terms, sorted(terms, key=lambda t: t.rank)
        try:
            self._build()
        except BaseException:  # whatever went wrong, the model is left as it was
            self.terms = old
            self._build()
            raise

    def add_term(self, term: Term) -> None:
        """Add a term (a probe, sutures ...); the pattern is widened if the term needs it. All or nothing."""
        self.set_terms(self.terms + [term])

    def remove_term(self, term: Term) -> None:
        """Remove a term the model holds (``ValueError`` if it holds no such term). All or nothing."""
        if not any(t is term for t in self.terms):
            raise ValueError(f"the model holds no term {term!r}")
        self.set_terms([t for t in self.terms if t is not term])

    def remapped(self, meshmap, state=()) -> tuple["Model", tuple]:
        """This model on the mesh of a topology change (a :class:`~tissuefem.engine.meshes.MeshMap`: a cut or an
        excision), and ``state`` (dof vectors; ``None`` stays ``None``), each copy of a node taking its parent's
        values. Terms are carried by their ``remap`` (dropped if nothing survives), handles by :meth:`Handle.remap`
        (the copies with material at their place, ``meshmap.material``); the elastic term is the new model's own, with
        the weights of ``meshmap``. P1 only."""
        if self.order != 1:
            raise ParameterError("order", "remapped: a topology change needs P1 elements (order=1)")
        if self.dim != 2:
            raise ParameterError("mesh", "remapped: cuts and excisions are 2D only for now; the mesh has tetrahedra")
        carried = [t.remap(meshmap) for t in self.terms if not isinstance(t, Elastic)]
        handles = [m for m in (h.remap(meshmap.parent, meshmap.material) for h in self.handles) if m is not None]
        model = Model(meshmap.mesh, self.material, order=1, intorder=self.intorder, assembly=self.assembly,
                      density=self.density, weights=meshmap.weights, handles=handles,
                      terms=[t for t in carried if t is not None], _meshmap=meshmap)
        if self.handles and not model.dynamic:  # a quasistatic body needs a hold on every piece
            if not model.handles:
                raise ParameterError("handles", "remapped: a quasistatic model needs at least one handle; this change "
                                                "leaves none (a dynamic model would let the body fall)")
            free = model.unheld_nodes()
            if free.size:
                raise ParameterError("handles", f"remapped: this change leaves nodes {index_list(free)} in pieces no "
                                                "handle holds, which have no quasistatic equilibrium; remove them "
                                                "(an excision) or make the model dynamic")
        return model, tuple(None if s is None else meshmap.transfer_dofs(s) for s in state)

    def unheld_nodes(self) -> np.ndarray:
        """The mesh vertices (sorted) of the pieces no handle holds: the pieces of the model's sparsity pattern (the
        mesh, joined by the couplings of the terms: sutures) with no held dof (in a quasistatic model their stiffness
        matrix is singular)."""
        graph = self.pattern.csr(np.ones(self.pattern.nnz))
        _, labels = csgraph.connected_components(graph, directed=False)
        held = np.zeros(labels.max() + 1, dtype=bool)
        for h in self.handles:
            held[labels[h._dofs]] = True
        return np.flatnonzero(~held[labels[self.basis.nodal_dofs[0]]])

    def terms_of(self, kind) -> list:
        return [t for t in self.terms if isinstance(t, kind)]

    def _first(self, kind):
        return next((t for t in self.terms if isinstance(t, kind)), None)

    inertia = property(lambda self: self._first(Inertia), doc="The inertia term, or ``None`` (quasistatic).")
    dynamic = property(lambda self: self.inertia is not None)
    loads = property(lambda self: self.terms_of(Load))
    probes = property(lambda self: self.terms_of(Probe))
    sutures = property(lambda self: self._first(Sutures))
    contact = property(lambda self: self._first(Contact), doc="The self-contact term, or ``None``.")

    # ------------------------------------------------------------------ step hooks (terms that have them only)
    @property
    def step_limit(self):
        """``None`` when no term limits steps; else ``limit(u, du)``: the largest fraction of the step ``du`` from
        ``u`` every term allows (contact: no surface passes through another)."""
        if not self._limit_terms:
            return None
        terms = list(self._limit_terms)
        return lambda u, du: min(t.max_step(u, du) for t in terms)

    notes_steps = property(lambda self: bool(self._step_terms), doc="Whether a term wants begin_step.")

    def begin_step(self, u, previous=None) -> int:
        """Tell the terms a step starts at ``u`` (reached from ``previous`` by the handles' motion); returns the
        crossings found (points the handles dragged through the surface, ignored by contact until back out)."""
        return sum(int(t.begin_step(u, previous) or 0) for t in self._step_terms)

    def end_step(self) -> None:
        for t in self._step_terms:
            t.end_step()

    term_names = property(lambda self: [t.name for t in self.terms], doc="The terms' names, in order.")

    def describe(self) -> list[str]:
        return [t.describe() for t in self.terms]

    @property
    def has_safe_hessian(self) -> bool:
        """Whether a term offers a positive semi-definite Hessian besides its exact one."""
        return (any(hasattr(t.density, "safe_tangent") for t in self._element_terms)
                or any(t.has_safe_hessian for t in self._other_terms))

    quadratic = property(lambda self: all(t.quadratic for t in self.terms), doc="A constant Hessian?")

    @property
    def external(self) -> np.ndarray:
        """The sum of the constant loads (a dof vector)."""
        f = np.zeros(self.n_dofs)
        for load in self.loads:
            f += load.scale * load.vector
        return f

    # ------------------------------------------------------------------ the potential
    def energy(self, u) -> float:
        """The potential ``E(u)``: the sum of every term's energy."""
        u = self._check_u(u)
        e = self.assembler.energy(u, self._density)
        for t in self._other_terms:
            e += t.energy(u)
        return e

    def gradient(self, u) -> np.ndarray:
        """``dE/du``: the residual (internal forces minus loads, plus inertia)."""
        u = self._check_u(u)
        g = self.assembler.residual(u, self._density)
        for t in self._other_terms:
            g += t.gradient(u)
        return g

    def hessian(self, u, safe: bool = False) -> sp.csr_matrix:
        """``d^2E/du^2`` on the model's fixed pattern (the Newton matrix). ``safe=True`` takes the terms' positive
        semi-definite variants where they offer one: the minimiser's fallback when the exact one gives no descent."""
        u = self._check_u(u)
        if self._pattern_terms and not all(t.covers(u) for t in self._pattern_terms):
            self._build()  # a term's couplings changed (contact pairs): a new pattern, the same terms
        data = self.pattern.zeros()
        density = self._safe_density if safe else self._density
        self.pattern.add_base(data, self.assembler.tangent(u, density).data)
        for t in self._other_terms:
            t.add_hessian(u, data, safe=safe)
        return self.pattern.csr(data)

    def _stored_terms(self):
        return [t for t in self.terms if not isinstance(t, (Inertia, Load))]

    def stored_energy(self, u) -> float:
        """The stored energy of the body and its tools: every term but inertia and the loads."""
        return sum(t.energy(u) for t in self._stored_terms())

    def internal_force(self, u) -> np.ndarray:
        """The gradient of :meth:`stored_energy`: the forces the body (and its tools) exert on the nodes."""
        g = np.zeros(self.n_dofs)
        for t in self._stored_terms():
            g += t.gradient(u)
        return g

    def _check_u(self, u) -> np.ndarray:
        u = np.asarray(u, dtype=float)
        if u.shape != (self.n_dofs,):
            raise ValueError(f"u must be a displacement vector of shape ({self.n_dofs},), got shape {u.shape}")
        return u

    # ------------------------------------------------------------------ post-processing
    def zeros(self) -> np.ndarray:
        return np.zeros(self.n_dofs)

    def nodal_displacement(self, u) -> np.ndarray:
        """Displacement at the mesh vertices ``(d, n_vertices)``."""
        return np.asarray(u)[self.basis.nodal_dofs]

    def positions(self, u) -> np.ndarray:
        """Deformed vertex positions ``x = X + u`` ``(d, n_vertices)``."""
        return self.X + self.nodal_displacement(u)

    deformed_positions = positions

    def element_areas(self) -> np.ndarray:
        """Material area of every element (the triangle's area times its weight)."""
        a = getattr(self.assembler, "areas", None)
        return a if a is not None else np.asarray(self.assembler._dx.sum(axis=1))

    def deformation_gradient(self, u) -> np.ndarray:
        """``F = I + grad u``: ``[d, d, n_elements]`` for P1, ``[d, d, n_elements, n_points]`` otherwise."""
        return self.assembler.deformation_gradient(self._check_u(u))

    def jacobian(self, u) -> np.ndarray:
        """``J = det F``, the ratio of deformed to rest area (volume): ``(n_elements,)`` for P1, ``(n_elements,
        n_points)`` otherwise. ``J <= 0``: the element is inverted (or flat) there."""
        return det(self.deformation_gradient(u))

    def stress(self, u) -> np.ndarray:
        """First Piola-Kirchhoff stress of every element (or quadrature point): the element terms' P summed."""
        F = self.deformation_gradient(u)
        return np.broadcast_to(self._density.stress(F), F.shape)

    def cauchy_stress(self, u) -> np.ndarray:
        """Cauchy stress ``sigma = P F^T / J``: the force per unit *deformed* area (see chapter 3)."""
        F = self.deformation_gradient(u)
        P = np.broadcast_to(self._density.stress(F), F.shape)
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.einsum("ik...,jk...->ij...", P, F) / det(F)

    def tension(self, u) -> np.ndarray:
        """The largest principal Cauchy stress of every element (positive = pulled apart)."""
        s = self.cauchy_stress(u)
        if self.dim == 3:  # the largest eigenvalue of the symmetric part
            sym = 0.5 * (s + s.swapaxes(0, 1))
            return np.linalg.eigvalsh(np.moveaxis(sym, (0, 1), (-2, -1)))[..., -1]
        mean = 0.5 * (s[0, 0] + s[1, 1])
        radius = np.hypot(0.5 * (s[0, 0] - s[1, 1]), 0.5 * (s[0, 1] + s[1, 0]))
        return mean + radius

    def total_mass(self) -> float:
        """``rho0`` times the material area (volume)."""
        return self.density * float(self.element_areas().sum())

    def __repr__(self):
        kind = "triangles" if self.dim == 2 else "tetrahedra"
        return (f"Model({self.mesh.nelements} {kind}, P{self.order}, {self.n_dofs} dofs, "
                f"terms {self.term_names}, {len(self.handles)} handles)")
