"""The engine: everything that computes, and nothing that draws or schedules a chapter.

* materials: :mod:`.materials1d`, :mod:`.materials`, :mod:`.inversion`, :mod:`.parameters`, :mod:`.constants`;
* geometry and discretisation: :mod:`.meshes`, :mod:`.forms` (the readable scikit-fem forms),
  :mod:`.assembly` (the fast P1 path, the vectorised quadrature path for P2, the forms as a reference);
* the model: :mod:`.terms` (elastic, fibres, inertia, loads, probe, sutures: one interface),
  :mod:`.contact` (self-contact of the surface: a term with collision detection) and
  :mod:`.model` (a body and exactly its terms, its handles, one sparsity pattern);
* solving: :mod:`.minimize` (the one Newton minimiser), :mod:`.linsolve` (backends and the one
  factorization-reuse policy), :mod:`.stepping` (quasistatic and backward-Euler steps, load stepping),
  :mod:`.realtime` (the frame loop with a budget), :mod:`.explicit` (symplectic Euler and its limit);
* the 1D bar of chapters 1 and 2: :mod:`.bar1d`.

The engine imports scikit-fem, numpy and scipy, never the surgery or workbook layers.
"""
