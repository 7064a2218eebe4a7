"""The engine: everything that computes, and nothing that draws or schedules a chapter.

Materials (:mod:`.materials1d`, :mod:`.materials`, :mod:`.inversion`, :mod:`.parameters`, :mod:`.constants`);
geometry and discretisation (:mod:`.meshes`, :mod:`.forms`: the readable scikit-fem forms, :mod:`.assembly`:
the fast paths); the model (:mod:`.terms`, :mod:`.contact`, :mod:`.model`: a body, its terms and handles, one
sparsity pattern); solving (:mod:`.minimize`: the one Newton minimiser, :mod:`.linsolve`, :mod:`.stepping`,
:mod:`.realtime`, :mod:`.explicit`); the 1D bar of chapters 1 and 2 (:mod:`.bar1d`). The engine imports
scikit-fem, numpy and scipy, never the surgery or workbook layers.
"""
