"""Quasistatic 2D hyperelasticity: Newton with load stepping, handles and tractions.

Ignoring inertia, equilibrium ``-div P = f`` in weak form (the notes'
"Equilibrium and weak form") reads ``q(u) = f_int(u) - f_ext = 0`` with

    f_int_a = int grad(v_a) : P(F) dX,
    f_ext_a = int_dB0 v_a . t dS + int_B0 v_a . b dX,

where ``t = P n`` is a traction (force per reference length) on part of the
boundary and ``b`` a body force. It is the gradient of the total potential
``E(u) = int Psi(F) dX - f_ext . u``, so a Newton step can be safeguarded by
a line search on ``E``.

Displacements are prescribed through :class:`Handle` objects: a set of
material points (a named boundary, a list of mesh nodes, or a mask on
coordinates) held at positions given by a translation or by a map
``X -> x``. A fixed edge is a handle that does not move. Handles are the hook
that user input drives later (a mouse drag moves a handle's target).
Prescribed degrees of freedom are eliminated (condensation): Newton solves
only for the free ones.

Loads and handle displacements are ramped together over ``load_steps``
(load stepping); each step warm-starts from the previous one.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp
from skfem import Basis, ElementTriP1, ElementTriP2, ElementVector, FacetBasis, LinearForm, asm

from .forms import energy_form, residual_form, tangent_form
from .newton import NewtonResult, newton_solve


class Handle:
    """Material points held at prescribed positions.

    Parameters
    ----------
    region
        Which points: a boundary name of the mesh (``"left"``), an array of
        mesh node indices, or a callable ``mask(X) -> bool`` on reference
        coordinates ``X`` shaped ``(2, n)``.
    target
        Where they go: a translation ``(dx, dy)`` (default: no motion, i.e. a
        fixed region), or a callable ``phi(X) -> x`` giving the deformed
        position of each point (``(2, n) -> (2, n)``).
    """

    def __init__(self, region, target=(0.0, 0.0)):
        if not (isinstance(region, str) or callable(region)):
            region = np.asarray(region)
            if region.ndim != 1 or region.size == 0 or not np.issubdtype(region.dtype, np.integer):
                raise ValueError(f"region must be a boundary name, node indices or a callable, got {region!r}")
        self.region = region
        self.move(target)

    def move(self, target) -> None:
        """Set a new target (a translation ``(dx, dy)`` or a map ``phi``): user input enters here."""
        if callable(target):
            self.target = target
            return
        t = np.asarray(target, dtype=float)
        if t.shape != (2,):
            raise ValueError(f"target must be a translation of shape (2,) or a callable, got shape {t.shape}")
        if not np.all(np.isfinite(t)):
            raise ValueError(f"target must be finite, got {t}")
        self.target = t

    def positions(self, X) -> np.ndarray:
        """Deformed positions ``x`` of the reference points ``X`` (2, n)."""
        if callable(self.target):
            x = np.asarray(self.target(X), dtype=float)
            if x.shape != X.shape:
                raise ValueError(f"the handle's map returned shape {x.shape}, expected {X.shape}")
            if not np.all(np.isfinite(x)):
                raise ValueError("the handle's map returned non-finite positions")
            return x
        return X + self.target[:, None]

    def __repr__(self):
        return f"Handle({self.region!r}, target={self.target!r})"


@dataclass
class QuasistaticResult:
    """Displacement (dof vector), convergence flag and the Newton result of every load step."""

    u: np.ndarray
    converged: bool
    steps: list[NewtonResult] = field(default_factory=list)

    @property
    def newton_iterations(self) -> int:
        return sum(r.iterations for r in self.steps)

    @property
    def status(self) -> str:
        return self.steps[-1].status if self.steps else "not run"


class QuasistaticProblem:
    """A hyperelastic body at equilibrium under handles, tractions and a body force.

    Parameters
    ----------
    mesh : skfem.MeshTri
    material : a material of :mod:`tissuefem.materials`
    order : 1 or 2
        Lagrange order of the displacement.
    handles : list of Handle
        Prescribed positions (at least one, or the body can float away).
    tractions : dict, optional
        ``{boundary name: (tx, ty)}``: a constant traction (dead load, per unit
        reference length) on a named boundary.
    body_force : (bx, by), optional
        A constant body force per unit reference area (gravity: ``(0, -rho0 g)``).
    assembly : "fast" or "forms"
        P1 only: the vectorised :class:`~tissuefem.assembly.P1Assembler`
        (default) or the scikit-fem reference forms. P2 always uses the forms.
    intorder : int, optional
        Degree of the quadrature rule of the basis (default ``2 order``:
        exact for the linear model's stiffness and the consistent mass).
        The P1 fast path needs no quadrature (one point is exact for its
        constant gradients) and ignores it.
    """

    def __init__(self, mesh, material, *, order: int = 1, handles=(), tractions=None, body_force=None,
                 assembly: str = "fast", intorder: int | None = None):
        if order not in (1, 2):
            raise ValueError(f"order must be 1 or 2, got {order!r}")
        if intorder is None:
            intorder = 2 * order
        if isinstance(intorder, bool) or not isinstance(intorder, (int, np.integer)) or not 1 <= intorder <= 19:
            raise ValueError(f"intorder must be an integer from 1 to 19, got {intorder!r}")
        if assembly not in ("fast", "forms"):
            raise ValueError(f"assembly must be 'fast' or 'forms', got {assembly!r}")
        from .assembly import P1Assembler

        P1Assembler._validate_mesh(mesh)  # finite coordinates, no zero-area or inverted (folded) triangles
        for what in ("energy", "stress", "tangent"):
            if not callable(getattr(material, what, None)):
                raise ValueError(f"material must have energy, stress and tangent methods, got {material!r}")
        self.mesh, self.material, self.order = mesh, material, order
        element = ElementVector(ElementTriP1() if order == 1 else ElementTriP2())
        self.basis = Basis(mesh, element, intorder=int(intorder))
        self.assembler = None
        if order == 1 and assembly == "fast":
            self.assembler = P1Assembler(mesh, material)
        self._forms = (residual_form(material), tangent_form(material), energy_form(material))
        # which displacement component each dof carries
        self.component = np.empty(self.basis.N, dtype=int)
        for dofs in (self.basis.nodal_dofs, getattr(self.basis, "facet_dofs", np.zeros((2, 0), int))):
            if dofs.size:
                self.component[dofs[0]] = 0
                self.component[dofs[1]] = 1
        self.handles = list(handles)
        for h in self.handles:
            if not isinstance(h, Handle):
                raise ValueError(f"handles must be Handle objects, got {h!r}")
        self._handle_dofs = [self._dofs_of(h.region) for h in self.handles]
        if not self.handles:
            raise ValueError("handles: give at least one Handle (e.g. a fixed edge), or the body floats freely")
        self.external = np.zeros(self.basis.N)
        for name, t in (tractions or {}).items():
            self.external += self._traction_vector(name, t)
        if body_force is not None:
            self.external += self._body_force_vector(body_force)

    # --- set-up helpers -----------------------------------------------------
    def _dofs_of(self, region) -> np.ndarray:
        basis, mesh = self.basis, self.mesh
        if isinstance(region, str):
            if mesh.boundaries is None or region not in mesh.boundaries:
                names = sorted(mesh.boundaries) if mesh.boundaries else []
                raise ValueError(f"handle region {region!r} is not a boundary of the mesh; boundaries: {names}")
            return np.asarray(basis.get_dofs(region).all(), dtype=int)
        if callable(region):
            mask = np.asarray(region(basis.doflocs), dtype=bool)
            dofs = np.flatnonzero(mask)
        else:
            nodes = np.asarray(region)
            if nodes.min() < 0 or nodes.max() >= mesh.nvertices:
                raise ValueError(f"handle region has node indices outside 0..{mesh.nvertices - 1}")
            dofs = basis.nodal_dofs[:, nodes].ravel()
            if self.order == 2:  # edge midpoints between two held nodes are held too
                held = np.zeros(mesh.nvertices, dtype=bool)
                held[nodes] = True
                edges = np.flatnonzero(held[mesh.facets[0]] & held[mesh.facets[1]])
                dofs = np.concatenate([dofs, basis.facet_dofs[:, edges].ravel()])
        if dofs.size == 0:
            raise ValueError(f"handle region {region!r} selects no point of the mesh")
        return np.unique(dofs)

    def _traction_vector(self, name, t) -> np.ndarray:
        t = np.asarray(t, dtype=float)
        if t.shape != (2,) or not np.all(np.isfinite(t)):
            raise ValueError(f"tractions[{name!r}] must be a finite vector (tx, ty), got {t!r}")
        if self.mesh.boundaries is None or name not in self.mesh.boundaries:
            raise ValueError(f"tractions: {name!r} is not a boundary of the mesh")
        fb = FacetBasis(self.mesh, self.basis.elem, facets=self.mesh.boundaries[name], intorder=2 * self.order)

        @LinearForm
        def traction(v, w):
            return t[0] * v[0] + t[1] * v[1]

        return asm(traction, fb)

    def _body_force_vector(self, b) -> np.ndarray:
        b = np.asarray(b, dtype=float)
        if b.shape != (2,) or not np.all(np.isfinite(b)):
            raise ValueError(f"body_force must be a finite vector (bx, by), got {b!r}")

        @LinearForm
        def body(v, w):
            return b[0] * v[0] + b[1] * v[1]

        return asm(body, self.basis)

    # --- energy, residual, tangent -----------------------------------------------
    def strain_energy(self, u) -> float:
        if self.assembler is not None:
            return self.assembler.energy(u)
        return float(asm(self._forms[2], self.basis, u=self.basis.interpolate(u)))

    def internal_force(self, u) -> np.ndarray:
        if self.assembler is not None:
            return self.assembler.residual(u)
        return asm(self._forms[0], self.basis, u=self.basis.interpolate(u))

    def tangent(self, u) -> sp.csr_matrix:
        if self.assembler is not None:
            return self.assembler.tangent(u)
        return asm(self._forms[1], self.basis, u=self.basis.interpolate(u)).tocsr()

    def prescribed(self) -> tuple[np.ndarray, np.ndarray]:
        """The prescribed dofs and their displacement values from the handles' current targets.

        Where handles overlap, the later handle wins.
        """
        X = self.basis.doflocs
        all_dofs, all_values = [], []
        for h, dofs in zip(self.handles, self._handle_dofs):
            u = h.positions(X[:, dofs]) - X[:, dofs]
            all_dofs.append(dofs)
            all_values.append(u[self.component[dofs], np.arange(dofs.size)])
        dofs, values = np.concatenate(all_dofs), np.concatenate(all_values)
        # keep the last occurrence of each dof: unique over the reversed list
        unique, first_in_reversed = np.unique(dofs[::-1], return_index=True)
        return unique, values[::-1][first_in_reversed]

    # --- solving ----------------------------------------------------------------
    def solve(self, load_steps: int = 1, u0=None, **newton_options) -> QuasistaticResult:
        """Ramp loads and handle displacements over ``load_steps`` and solve each with Newton.

        ``newton_options`` go to :func:`tissuefem.newton.newton_solve` (``rtol``,
        ``max_iter``, ``line_search``...). Returns the last converged state if a
        step fails (``converged`` is then False).
        """
        if int(load_steps) != load_steps or load_steps < 1:
            raise ValueError(f"load_steps must be a positive integer, got {load_steps!r}")
        u = self.basis.zeros() if u0 is None else np.array(u0, dtype=float, copy=True)
        if u.shape != (self.basis.N,):
            raise ValueError(f"u0 must have shape ({self.basis.N},), got {u.shape}")
        if not np.all(np.isfinite(u)):
            raise ValueError("u0 contains non-finite values")
        fixed, values = self.prescribed()
        start = u[fixed].copy()
        newton_options.setdefault("line_search", "energy")
        steps = []
        for s in np.arange(1, load_steps + 1) / load_steps:
            f_ext = s * self.external
            x0, load_norm = self._predict(u, fixed, start + s * (values - start), f_ext)
            result = newton_solve(
                x0,
                lambda x: self.internal_force(x) - f_ext,
                self.tangent,
                fixed=fixed,
                energy=lambda x: self.strain_energy(x) - f_ext @ x,
                reference_norm=load_norm,
                **newton_options,
            )
            steps.append(result)
            if not result.converged:
                return QuasistaticResult(u, False, steps)
            u = result.x
        return QuasistaticResult(u, True, steps)

    def _predict(self, u, fixed, target, f_ext) -> tuple[np.ndarray, float]:
        """Initial guess for a load step: move the prescribed dofs and let the free ones follow.

        Moving only the prescribed dofs can invert the elements next to them
        (badly so for P2, whose edge midpoints stay behind). Instead, take one
        linearised step from the previous equilibrium ``u``:
        ``K_ff du_f = -(q_f(u) - f_ext_f) - K_fc du_c``. Falls back to moving the
        prescribed dofs alone if that prediction is not a valid state.

        Also returns the size of the step's load, ``||-q_f(u) + f_ext_f - K_fc du_c||``,
        the scale for Newton's relative tolerance.
        """
        x0 = u.copy()
        x0[fixed] = target
        free = np.setdiff1d(np.arange(u.size), fixed)
        try:
            K = self.tangent(u)
            r = self.internal_force(u) - f_ext
            if not (np.all(np.isfinite(K.data)) and np.all(np.isfinite(r))):
                return x0, 0.0  # e.g. ln J on an inverted start: no linearisation to take
            du_c = target - u[fixed]
            rhs = -r[free] - K[free][:, fixed] @ du_c
            du_f = sp.linalg.spsolve(K[free][:, free].tocsc(), rhs)
        except (RuntimeError, ValueError):
            return x0, 0.0
        load_norm = float(np.linalg.norm(rhs))
        guess = x0.copy()
        guess[free] = u[free] + du_f
        # keep the prediction only if it is a valid state that does not raise the energy
        # (far from equilibrium, e.g. releasing a crushed body, the linearisation means little)
        e_guess = self.strain_energy(guess) - f_ext @ guess if np.all(np.isfinite(guess)) else np.nan
        e_plain = self.strain_energy(x0) - f_ext @ x0
        if np.isfinite(e_guess) and not e_guess > e_plain:
            return guess, load_norm
        return x0, load_norm

    # --- post-processing -----------------------------------------------------------
    def nodal_displacement(self, u) -> np.ndarray:
        """Displacement at the mesh vertices, shape ``(2, n_vertices)``."""
        return np.asarray(u)[self.basis.nodal_dofs]

    def deformed_positions(self, u) -> np.ndarray:
        """Vertex positions ``x = X + u`` of the deformed mesh, shape ``(2, n_vertices)``."""
        return self.mesh.p + self.nodal_displacement(u)
