"""Assembly benchmark: scikit-fem forms versus the fast P1 path (and SuperLU for context).

:func:`assembly_benchmark` times, in one run and on the same meshes, what one Newton iteration of a 2D
Neo-Hookean problem costs to assemble:

* the reference path, :mod:`tissuefem.engine.forms` assembled by scikit-fem
  (``asm(tangent_form(material), basis, u=basis.interpolate(u))``, the ``BilinearForm`` way of scikit-fem's
  hyperelasticity example: the form is evaluated once per pair of local basis functions) and its residual;
* the fast path, :class:`tissuefem.engine.assembly.P1Assembler`;
* for context, a SuperLU factorization of the tangent with the left edge fixed, with the ``COLAMD`` and
  the ``MMD_AT_PLUS_A`` column orderings.

Every number is a median over ``repeats`` timings after one untimed warm-up, after one untimed pass at the
largest size (see the comment in :func:`assembly_benchmark`). A benchmark to *read*, not a timed test:
compare columns of one run rather than numbers across runs.
"""

from __future__ import annotations

import math
import time

import numpy as np
import scipy.sparse.linalg as spla
from skfem import Basis, ElementTriP1, ElementVector, asm

from ...engine.assembly import P1Assembler
from ...engine.constants import TISSUE_E, TISSUE_NU
from ...engine.parameters import check_count
from ...engine.forms import residual_form, tangent_form
from ...engine.materials import NeoHookean
from ...engine.meshes import mesh_with_about
from ..measure import median_time
from ..tables import markdown_table
from .common import check_sizes, machine_info, write_json

__all__ = ["assembly_benchmark", "format_table"]

_COLUMNS = [
    ("triangles", "triangles", "{:d}"),
    ("dofs", "dofs", "{:d}"),
    ("ref_tangent_ms", "ref K [ms]", "{:.1f}"),
    ("ref_residual_ms", "ref r [ms]", "{:.1f}"),
    ("fast_tangent_ms", "fast K [ms]", "{:.2f}"),
    ("fast_residual_ms", "fast r [ms]", "{:.2f}"),
    ("fast_both_ms", "fast r+K [ms]", "{:.2f}"),
    ("speedup_tangent", "speedup K", "{:.0f}x"),
    ("speedup", "speedup r+K", "{:.0f}x"),
    ("setup_ms", "fast setup [ms]", "{:.1f}"),
    ("splu_colamd_ms", "SuperLU COLAMD [ms]", "{:.1f}"),
    ("splu_mmd_ms", "SuperLU MMD_AT_PLUS_A [ms]", "{:.1f}"),
    ("rel_diff_tangent", "rel. diff K", "{:.1e}"),
]


def format_table(rows) -> str:
    """The benchmark rows as a Markdown table (one line per mesh size)."""
    return markdown_table(rows, _COLUMNS)


def assembly_benchmark(sizes=(2000, 8000, 32000), repeats=5, material=None, out=None, progress=print) -> list[dict]:
    """Time reference (scikit-fem forms) versus fast (P1Assembler) assembly; return one dict per size.

    ``sizes``: approximate triangle counts, each a unit square from
    :func:`tissuefem.engine.meshes.mesh_with_about`; ``repeats``: timed repetitions per measurement (the
    median is reported); ``material`` defaults to ``NeoHookean.from_young(1000, 0.3)``; ``out``: an optional
    JSON path for ``{"rows", "machine", "settings"}``; ``progress`` gets progress lines and finally the
    Markdown table (:func:`format_table`), ``None`` for silence.

    Each row has ``triangles``, ``dofs``, ``nnz``, the reference times ``ref_tangent_ms``/``ref_residual_ms``,
    the fast times ``fast_tangent_ms``/``fast_residual_ms``/``fast_both_ms`` (one ``residual_and_tangent``),
    ``speedup_tangent`` (reference K / fast K), ``speedup`` (reference K + r over fast r + K), the fast path's
    one-off ``setup_ms``, SuperLU times ``splu_colamd_ms`` and ``splu_mmd_ms``, and
    ``rel_diff_tangent``/``rel_diff_residual`` (relative Frobenius difference of the two paths, a sanity check).
    """
    sizes = check_sizes(sizes)
    repeats = check_count("repeats", repeats)
    if material is None:
        material = NeoHookean.from_young(TISSUE_E, TISSUE_NU)
    say = progress if progress is not None else (lambda *_: None)

    K_form, r_form = tangent_form(material), residual_form(material)

    def make_case(n_target):
        mesh = mesh_with_about(n_target)
        t0 = time.perf_counter()
        fast = P1Assembler(mesh, material)
        setup_ms = 1e3 * (time.perf_counter() - t0)
        basis = Basis(mesh, ElementVector(ElementTriP1()))
        rng = np.random.default_rng(12345 + n_target)
        h = math.sqrt(2.0 / mesh.t.shape[1])  # typical edge length on the unit square
        u = 0.02 * h * rng.standard_normal(basis.N)
        return mesh, fast, setup_ms, basis, u

    # Warm the allocator up on the largest case first. glibc's malloc raises its mmap/trim thresholds only
    # after large blocks have been freed, so whichever size runs first pays page faults for its temporaries
    # (the reference path was 3-5x slower at 8k triangles right after 2k than after 32k). One pass at the
    # largest size puts every row on the same footing (as would MALLOC_MMAP_THRESHOLD_ /
    # MALLOC_TRIM_THRESHOLD_ set before Python starts).
    cases = {max(sizes): make_case(max(sizes))}
    _, fast, _, basis, u = cases[max(sizes)]
    say(f"assembly benchmark: warm-up at {fast.n_elements} triangles ...")
    asm(K_form, basis, u=basis.interpolate(u))
    asm(r_form, basis, u=basis.interpolate(u))
    fast.residual_and_tangent(u)

    rows = []
    for n_target in sizes:
        case = cases.pop(n_target, None)
        mesh, fast, setup_ms, basis, u = case if case is not None else make_case(n_target)
        nel = mesh.t.shape[1]

        def ref_K():
            return asm(K_form, basis, u=basis.interpolate(u))

        def ref_r():
            return asm(r_form, basis, u=basis.interpolate(u))

        say(f"assembly benchmark: {nel} triangles, {basis.N} dofs ...")
        ref_tangent_ms = median_time(ref_K, repeats)
        ref_residual_ms = median_time(ref_r, repeats)
        fast_tangent_ms = median_time(lambda: fast.tangent(u), repeats)
        fast_residual_ms = median_time(lambda: fast.residual(u), repeats)
        fast_both_ms = median_time(lambda: fast.residual_and_tangent(u), repeats)

        K0, r0 = ref_K(), ref_r()
        r1, K1 = fast.residual_and_tangent(u)
        rel_K = float(spla.norm(K1 - K0) / spla.norm(K0))
        rel_r = float(np.linalg.norm(r1 - r0) / np.linalg.norm(r0))

        fixed = basis.get_dofs("left").flatten()
        free = np.setdiff1d(np.arange(basis.N), fixed)
        Kc = K1[free][:, free].tocsc()
        splu_colamd_ms = median_time(lambda: spla.splu(Kc, permc_spec="COLAMD"), repeats)
        splu_mmd_ms = median_time(lambda: spla.splu(Kc, permc_spec="MMD_AT_PLUS_A"), repeats)

        row = {"triangles": int(nel), "nodes": int(mesh.p.shape[1]), "dofs": int(basis.N), "nnz": int(fast.nnz),
               "ref_tangent_ms": ref_tangent_ms, "ref_residual_ms": ref_residual_ms,
               "fast_tangent_ms": fast_tangent_ms, "fast_residual_ms": fast_residual_ms, "fast_both_ms": fast_both_ms,
               "speedup_tangent": ref_tangent_ms / fast_tangent_ms,
               "speedup": (ref_tangent_ms + ref_residual_ms) / fast_both_ms, "setup_ms": setup_ms,
               "splu_colamd_ms": splu_colamd_ms, "splu_mmd_ms": splu_mmd_ms,
               "rel_diff_tangent": rel_K, "rel_diff_residual": rel_r}
        rows.append(row)
        say(f"  reference K {ref_tangent_ms:.1f} ms, fast K {fast_tangent_ms:.2f} ms "
            f"({row['speedup_tangent']:.0f}x); SuperLU COLAMD {splu_colamd_ms:.1f} ms, "
            f"MMD_AT_PLUS_A {splu_mmd_ms:.1f} ms")

    say(format_table(rows))
    if out is not None:
        write_json(out, {
            "benchmark": "assembly",
            "description": "Per Newton iteration, 2D P1 plane-strain hyperelasticity on the unit square: scikit-fem "
                           "forms (tissuefem.engine.forms) versus tissuefem.engine.assembly.P1Assembler; SuperLU "
                           "factorization of the tangent with the left edge fixed. Times in ms, medians after one "
                           "warm-up.",
            "settings": {"sizes": sizes, "repeats": repeats, "material": repr(material)},
            "machine": machine_info(), "rows": rows})
    return rows
