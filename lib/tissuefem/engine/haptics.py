"""The tool's force at haptic rate: a reduced model of one tool, built after a frame and evaluated between frames.

A haptic device asks for the force on the user's hand about 1000 times a second; a frame comes 30 times. After a
frame, :func:`tool_model` linearises the *converged frame's* force in the tool's position ``p`` (a handle's
translation target, or a probe's centre):

    f(p) = f0 + S (p - p0),

``f0`` the frame's force at its tool position ``p0`` and ``S`` the tool's stiffness seen through the body. The frame
is the minimum of the step's potential (:mod:`.stepping`), so its free dofs ``f`` satisfy ``g_f(u, p) = 0``; moving the
tool by ``dp`` moves them by ``du_f = -H_ff^-1 (dg_f/dp) dp``, ``H`` the frame's tangent (inertia's ``M/dt^2``
included), and the force by

    S = dF/dp - (dF/du_f) H_ff^-1 (dg_f/dp),

the Schur complement of the tool's unknowns:

* a **handle** holds its dofs ``t`` at ``B p`` (``B``: a 1 on each dof of each component). Its force is the reaction
  ``F = B^T q_t`` (:meth:`~.model.Model.reaction`, ``q`` the forces of the stored terms, whose Hessian ``K`` is ``H``
  less inertia's), so ``S = B^T K_tt B - (K_ft B)^T H_ff^-1 (H_ft B)``;
* a **probe** (:class:`~.terms.Probe`) pushes each surface node ``a`` inside its disc with a force that depends on
  ``x_a - c`` only; with ``P_a`` the probe's Hessian block at ``a`` (zero off the contact nodes), ``F = sum_a f_a``
  moves by ``sum_a P_a dc`` directly and by ``-P_a du_a`` through the body: ``S = sum_a P_a - P^T H_ff^-1 P``,
  ``P = K_probe E`` (``E``: a 1 on each dof of each component).

Both forces are what the tool exerts on the body (a device renders their opposite, the body's push on the hand).
Each column of ``H_ff^-1 (...)`` is one solve with the stepper's own linear solver, i.e. with its kept factorization
(CG preconditioned by it, or a back-substitution): ``d`` solves per frame, and an update between frames is a
``d x d`` product. The update is exact to first order in ``p - p0``: it misses what changes between frames (contacts
made or lost, the body's own motion, the material's nonlinearity over a large move).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .model import Handle
from .parameters import ParameterError, check_vector
from .stepping import Stepper
from .terms import Probe

__all__ = ["ToolModel", "tool_model"]

#: the relative residual of each solve with ``H_ff``: the stiffness to about six digits, far below the error of the
#: linearisation itself (a tighter one costs CG iterations, and a refactorization when CG slows down)
SOLVE_RTOL = 1e-6


@dataclass(frozen=True)
class ToolModel:
    """The reduced model of one tool after a frame: :meth:`force` ``(p) = force0 + stiffness (p - position)``.

    ``tool``: the handle's name or the probe's label; ``kind``: ``"handle"`` or ``"probe"``; ``position``: ``p0``
    (the handle's translation target, or the probe's centre); ``force0``: the force the tool exerts on the body at
    ``p0``; ``stiffness``: ``S`` ``(d, d)``; ``frame``: the frame it was built after. Immutable: a loop that reads it
    on another thread sees one whole model, the old one or the next one."""

    tool: str
    kind: str
    position: np.ndarray
    force0: np.ndarray
    stiffness: np.ndarray
    frame: int

    def force(self, position) -> np.ndarray:
        """The force at the tool position ``position`` (``(d,)``, checked: a ``ParameterError`` naming it)."""
        p = check_vector("position", position, self.position.size)
        return self.force0 + self.stiffness @ (p - self.position)

    __call__ = force


def _tool(model, tool):
    """The handle or probe ``tool`` (a name, a label, or the object) of ``model``, or a ``ParameterError``."""
    if isinstance(tool, (Handle, Probe)):
        held = model.handles if isinstance(tool, Handle) else model.probes
        if any(t is tool for t in held):
            return tool
        raise ParameterError("tool", f"tool: the model holds no {type(tool).__name__.lower()} {tool!r:.100}")
    probes = [p for p in model.probes if isinstance(tool, str) and p.label == tool]
    if probes:
        return probes[0]
    handles = [h for h in model.handles if isinstance(tool, str) and h.name == tool]
    if handles:
        return handles[0]
    raise ParameterError("tool", f"tool: no handle or probe named {tool!r:.100}; handles "
                                 f"{[h.name for h in model.handles]}, probes {[p.label for p in model.probes]}")


def _components(model, dofs) -> np.ndarray:
    """``(n_dofs, d)``: column ``j`` is 1 on the ``dofs`` of component ``j`` (the map ``B`` from a translation)."""
    E = np.zeros((model.n_dofs, model.dim))
    E[dofs, model.component[dofs]] = 1.0
    return E


def tool_model(stepper: Stepper, tool) -> ToolModel:
    """The reduced model of ``tool`` (a handle with a translation target, or a probe: its name, label or object) at
    the stepper's state, the last frame's result (see the module's docstring). Uses the stepper's linear solver and
    its kept factorization; changes no state (a failed solve raises ``ValueError`` and builds nothing)."""
    if not isinstance(stepper, Stepper):
        raise ParameterError("stepper", f"stepper must be a Stepper (a simulation's solver), got {stepper!r:.100}")
    model, u = stepper.model, stepper.u
    if model.order != 1:
        raise ParameterError("order", "tool_model: the reduced model of a tool needs P1 elements (order=1)")
    tool = _tool(model, tool)
    fixed, _ = model.prescribed()
    free = np.ones(model.n_dofs, dtype=bool)
    free[fixed] = False
    H = model.hessian(u)  # the frame's tangent at its result
    if not np.all(np.isfinite(H.data)):
        raise ValueError("tool_model: the frame's tangent is not finite")
    if isinstance(tool, Handle):
        if callable(tool.target):
            raise ParameterError("tool", f"tool: handle {tool.name!r} follows a map; only a translation target "
                                         "has a position to linearise in")
        B = _components(model, model.basis.nodal_dofs[:, tool.nodes].ravel())
        HB = H @ B
        inertia = model.inertia
        KB = HB if inertia is None else HB - np.column_stack([inertia.matvec(b) for b in B.T]) / inertia.dt**2
        direct, left, right = B.T @ KB, KB[free], HB[free]
        name, kind, position, force0 = tool.name, "handle", tool.target.copy(), model.reaction(u, tool)
    else:
        data = model.pattern.zeros()
        tool.add_hessian(u, data)  # the probe's own Hessian: its node blocks P_a
        E = _components(model, model.basis.nodal_dofs.ravel())
        KE = model.pattern.csr(data) @ E
        direct, left, right = E.T @ KE, KE[free], KE[free]
        name, kind, position, force0 = tool.label, "probe", tool.center.copy(), tool.forces(u).sum(axis=1)
    A = stepper.linear.matrix(lambda: H, free)
    columns = []
    for b in right.T:
        scale = float(np.linalg.norm(b))
        if scale == 0.0:  # a probe touching nothing: no coupling through the body
            columns.append(np.zeros_like(b))
            continue
        x, _ = stepper.linear.solve(A, b, atol=SOLVE_RTOL * scale)
        if x is None or not np.all(np.isfinite(x)):
            raise ValueError(f"tool_model: the solve with the frame's tangent failed for {kind} {name!r}")
        columns.append(x)
    stiffness = np.asarray(direct - left.T @ np.column_stack(columns), dtype=float)
    return ToolModel(name, kind, np.asarray(position, dtype=float), np.asarray(force0, dtype=float), stiffness,
                     int(stepper.steps))
