"""Self-contact of the boundary: surfaces that touch, press, slide, and never pass through each other.

A :class:`Contact` term is one more term of the incremental potential (:mod:`tissuefem.engine.terms`), with two
hooks that a model without contact never calls:

* its Hessian couples nodes that no element couples (two sides of a fold, two lips of a wound), and *which* nodes
  changes as the body moves. The model's sparsity pattern is widened with the couplings of the current candidate
  pairs and rebuilt (a merge of a few keys, ~4 ms at 8k triangles) only when a pair appears that the pattern does
  not hold (:meth:`Contact.covers`);
* a state on the far side of a surface must never be reached. The minimiser asks :meth:`Contact.max_step` for the
  largest fraction of a Newton step free of crossings (continuous collision detection) before its line search, and
  the stepper asks the same of its warm start (:func:`tissuefem.engine.minimize.newton`, ``step_limit``).

A handle that drags tissue through tissue is obeyed: its crossings are counted (:meth:`Contact.begin_step`, in
``StepReport.crossed``) while the points stay through, and contact acts again once they are back out. After a cut,
:meth:`Contact.remap` gives the same contact on the new mesh.

The pieces, each a module:

* :mod:`.surface` -- :class:`ContactSurface`, points as linear combinations of nodes and the segments between them;
* :mod:`.barrier` -- the one-sided barrier ``beta`` on signed gaps (why, and its derivatives);
* :mod:`.candidates` -- the signed gap of a (point, segment) pair, which pairs may touch (neighbourhoods, hinges,
  rest offsets, owners) and the Verlet list that finds them;
* :mod:`.collision` -- continuous collision detection: times of impact and the largest safe step;
* :mod:`.term` -- :class:`Contact`, the term that composes them.

References
----------
.. [1] M. Li, Z. Ferguson, T. Schneider, T. Langlois, D. Zorin, D. Panozzo, C. Jiang, D. M. Kaufman, *Incremental
   Potential Contact: intersection- and inversion-free, large-deformation dynamics*, ACM Transactions on Graphics
   39(4) (SIGGRAPH 2020), 49.
.. [2] M. Li, D. M. Kaufman, C. Jiang, *Codimensional Incremental Potential Contact*, ACM Transactions on Graphics
   40(4) (SIGGRAPH 2021), 170.
.. [3] J. A. Baerentzen, H. Aanaes, *Signed distance computation using the angle weighted pseudonormal*, IEEE
   Transactions on Visualization and Computer Graphics 11(3) (2005), 243-253.
.. [4] L. Verlet, *Computer "experiments" on classical fluids. I. Thermodynamical properties of Lennard-Jones
   molecules*, Physical Review 159(1) (1967), 98-103.
"""

from .barrier import barrier
from .collision import SAFETY
from .surface import ContactSurface
from .term import Contact

__all__ = ["ContactSurface", "Contact", "barrier", "SAFETY"]
