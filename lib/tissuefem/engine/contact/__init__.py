"""Self-contact of the boundary: surfaces that touch, press, slide, and never pass through each other.

A :class:`Contact` term is one more term of the incremental potential (:mod:`tissuefem.engine.terms`), with hooks a
model without contact never calls. Its Hessian couples nodes no element couples (two sides of a fold, two lips of a
wound), and *which* nodes changes as the body moves: the model's pattern is widened with the couplings of the current
candidate pairs and rebuilt (a merge of a few keys, ~4 ms at 8k triangles) only when a pair appears that it does not
hold (:meth:`Contact.covers`). A state on the far side of a surface must never be reached: the minimiser asks
:meth:`Contact.max_step` for the largest fraction of a Newton step free of crossings before its line search, the
stepper the same of its warm start (``step_limit`` of :func:`tissuefem.engine.minimize.newton`). A handle that drags
tissue through tissue is obeyed; its crossings are counted (:meth:`Contact.begin_step`, ``StepReport.crossed``) while
the points stay through. After a cut, :meth:`Contact.remap` gives the same contact on the new mesh.

The pieces: :mod:`.surface` (:class:`ContactSurface`), :mod:`.barrier` (on signed gaps, and why),
:mod:`.candidates` (signed gaps; which pairs may touch), :mod:`.collision` (times of impact) and :mod:`.term`.

References
----------
.. [1] M. Li et al., *Incremental Potential Contact: intersection- and inversion-free, large-deformation dynamics*,
   ACM Transactions on Graphics 39(4) (2020), 49.
.. [2] M. Li, D. M. Kaufman, C. Jiang, *Codimensional Incremental Potential Contact*, ACM TOG 40(4) (2021), 170.
.. [3] J. A. Baerentzen, H. Aanaes, *Signed distance computation using the angle weighted pseudonormal*, IEEE TVCG
   11(3) (2005), 243-253.
.. [4] L. Verlet, *Computer "experiments" on classical fluids. I.*, Physical Review 159(1) (1967), 98-103.
"""

from .barrier import barrier
from .collision import SAFETY
from .surface import ContactSurface
from .term import Contact

__all__ = ["ContactSurface", "Contact", "barrier", "SAFETY"]
