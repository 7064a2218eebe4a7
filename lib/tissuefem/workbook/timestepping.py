"""The studies of chapter 7 (time stepping): the CFL condition of the explicit scheme, measured.

:func:`cfl_study` measures symplectic Euler's largest stable time step on a flap
refined several times and checks that it scales like the element size ``h``
(the Courant-Friedrichs-Lewy condition; :mod:`tissuefem.engine.explicit` derives it).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

from ..engine.constants import TISSUE_DENSITY, TISSUE_E, TISSUE_NU
from ..engine.explicit import critical_time_step, largest_stable_dt, wave_speed
from ..engine.materials import StableNeoHookean
from ..engine.meshes import mesh_size, rectangle
from ..engine.model import Handle, Model
from ..engine.parameters import lame_parameters
from .measure import power_law_fit

__all__ = ["CFLStudy", "cfl_study"]


@dataclass
class CFLStudy:
    """Rows of :func:`cfl_study` and the fitted exponents.

    ``rows`` (iterating the study yields them) are dicts with ``nx``, ``h``, ``dofs``, ``dt_measured``,
    ``dt_estimate`` (``2 / omega_max``), ``ratio`` (measured / estimate), ``courant`` (``dt_measured c / h``)
    and ``seconds``. The fit ``dt_measured = constant h^exponent`` has ``exponent`` 1 under the CFL
    condition; ``exponent_estimate`` is the same slope for the estimate.
    """

    rows: list = field(default_factory=list)
    exponent: float = float("nan")
    exponent_estimate: float = float("nan")
    constant: float = float("nan")
    wave_speed: float = float("nan")

    def __iter__(self):
        return iter(self.rows)

    def __len__(self):
        return len(self.rows)

    def __getitem__(self, i):
        return self.rows[i]


def cfl_study(sizes=(4, 8, 16, 32), *, E: float = TISSUE_E, nu: float = TISSUE_NU, density: float = TISSUE_DENSITY,
              material=None, width: float = 2.0, height: float = 1.0, **measure) -> CFLStudy:
    """Measured largest stable ``dt`` of :class:`SymplecticEuler` on a flap refined ``nx = sizes``.

    The flap ``width x height`` has square cells of side ``h = width / nx`` and its left edge fixed; the
    material defaults to stable neo-Hookean with plane-strain Lamé parameters from ``E, nu``. For each mesh:
    :func:`largest_stable_dt` (``measure`` goes to it), the estimate :func:`critical_time_step` and their
    ratio. The CFL condition predicts ``dt ~ h`` (exponent 1).
    """
    if material is None:
        material = StableNeoHookean(*lame_parameters(E, nu, "strain"))
    c = wave_speed(material, density)
    study = CFLStudy(wave_speed=c)
    for nx in sizes:
        mesh = rectangle(width, height, nx, max(1, int(round(nx * height / width))))
        model = Model(mesh, material, handles=[Handle("left")], density=density)
        h = mesh_size(mesh)
        t0 = time.perf_counter()
        measured = largest_stable_dt(model, **measure)
        seconds = time.perf_counter() - t0
        estimate = critical_time_step(model)
        study.rows.append({"nx": int(nx), "h": h, "dofs": int(model.n_dofs), "dt_measured": measured,
                           "dt_estimate": estimate, "ratio": measured / estimate, "courant": measured * c / h,
                           "seconds": seconds})
    if len(study.rows) >= 2:
        h = [r["h"] for r in study.rows]
        study.exponent, study.constant = power_law_fit(h, [r["dt_measured"] for r in study.rows])
        study.exponent_estimate, _ = power_law_fit(h, [r["dt_estimate"] for r in study.rows])
    return study
