"""Self-contact of the boundary: surfaces that touch, press, slide, and never pass through each other.

:class:`Contact` (:mod:`.term`) is a term of the incremental potential whose Hessian couples nodes no element couples
(two lips of a wound); the model's pattern is rebuilt only when a pair appears that it lacks (:meth:`Contact.covers`).
Newton and the stepper take at most :meth:`Contact.max_step` of a step, so no state beyond a surface is reached;
handles dragging tissue through tissue are obeyed and the crossings counted (:meth:`Contact.begin_step`). The pieces:
:mod:`.surface`, :mod:`.barrier`, :mod:`.candidates` (signed gaps, pairs), :mod:`.collision` (times of impact).
References:

.. [1] M. Li et al., *Incremental Potential Contact: intersection- and inversion-free, large-deformation dynamics*,
   ACM Transactions on Graphics 39(4) (2020), 49.
.. [2] M. Li, D. M. Kaufman, C. Jiang, *Codimensional Incremental Potential Contact*, ACM TOG 40(4) (2021), 170.
.. [3] J. A. Baerentzen, H. Aanaes, *Signed distance computation using the angle weighted pseudonormal*, IEEE TVCG
   11(3) (2005), 243-253.
.. [4] L. Verlet, *Computer "experiments" on classical fluids. I.*, Physical Review 159(1) (1967), 98-103.
"""

from .barrier import barrier
from .surface import ContactSurface
from .term import Contact

__all__ = ["ContactSurface", "Contact", "barrier"]
