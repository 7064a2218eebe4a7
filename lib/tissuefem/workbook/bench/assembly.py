"""Assembly benchmark: one Neo-Hookean Newton iteration's assembly by scikit-fem's forms
(:mod:`tissuefem.engine.forms`) and by :class:`tissuefem.engine.assembly.P1Assembler`, and SuperLU's
factorization (``COLAMD``, ``MMD_AT_PLUS_A``) for context. Compare columns of one run, not runs."""

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
from .common import check_sizes, machine_info, median_rows, recorded, write_record

__all__ = ["assembly_benchmark", "format_table", "recorded_assembly_table"]

_COLUMNS = [("triangles", "triangles", "{:d}"), ("dofs", "dofs", "{:d}"), ("ref_tangent_ms", "ref K [ms]", "{:.1f}"),
            ("ref_residual_ms", "ref r [ms]", "{:.1f}"), ("fast_tangent_ms", "fast K [ms]", "{:.2f}"),
            ("fast_residual_ms", "fast r [ms]", "{:.2f}"), ("fast_both_ms", "fast r+K [ms]", "{:.2f}"),
            ("speedup_tangent", "speedup K", "{:.0f}x"), ("speedup", "speedup r+K", "{:.0f}x"),
            ("setup_ms", "fast setup [ms]", "{:.1f}"), ("splu_colamd_ms", "SuperLU COLAMD [ms]", "{:.1f}"),
            ("splu_mmd_ms", "SuperLU MMD_AT_PLUS_A [ms]", "{:.1f}"), ("rel_diff_tangent", "rel. diff K", "{:.1e}")]


#: the recorded table's columns (docs/benchmarks.md prints it)
_RECORDED = [("triangles", "triangles", "{:d}"), ("ref_tangent_ms", "scikit-fem `BilinearForm` ms", "{:.1f}"),
             ("fast_tangent_ms", "fast P1 path ms", "{:.2f}"), ("speedup_tangent", "speed-up", "{:.0f}x"),
             ("splu_colamd_ms", "SuperLU COLAMD ms", "{:.1f}"), ("splu_mmd_ms", "SuperLU MMD_AT_PLUS_A ms", "{:.1f}")]


def recorded_assembly_table() -> str:
    """The recorded run shipped with the package (``data/assembly.json``, its rounds' medians) as the Markdown
    table docs/benchmarks.md shows: the tangent's assembly and its factorization."""
    record = recorded("assembly")
    return markdown_table(median_rows([r["rows"] for r in record["rounds"]], "triangles"), _RECORDED)


def format_table(rows) -> str:
    """The benchmark rows as a Markdown table (one line per mesh size)."""
    return markdown_table(rows, _COLUMNS)


def assembly_benchmark(sizes=(2000, 8000, 32000), repeats=5, out=None, progress=print) -> list[dict]:
    """Time the reference against the fast assembly on unit squares of about ``sizes`` triangles; one dict per
    size: median ms of each path (``ref_*``, ``fast_*``), ``speedup``, the fast path's ``setup_ms``, SuperLU
    times and ``rel_diff_*`` (the paths' relative difference); JSON and CSV into the folder ``out``."""
    sizes = check_sizes(sizes)
    repeats = check_count("repeats", repeats)
    material = NeoHookean.from_young(TISSUE_E, TISSUE_NU)
    say = progress if progress is not None else (lambda *_: None)
    machine = machine_info()  # at the start: the load average says how quiet the machine was

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

    # warm the allocator up at the largest size: glibc's malloc raises its mmap/trim thresholds only after
    # large blocks were freed, so the first size would pay page faults (3-5x slower) for its temporaries
    cases = {max(sizes): make_case(max(sizes))}
    _, fast, _, basis, u = cases[max(sizes)]
    say(f"assembly benchmark: warm-up at {fast.n_elements} triangles ...")
    asm(K_form, basis, u=basis.interpolate(u))
    asm(r_form, basis, u=basis.interpolate(u))
    fast.residual_and_tangent(u)

    rows = []
    for n_target in sizes:
        mesh, fast, setup_ms, basis, u = cases.pop(n_target, None) or make_case(n_target)
        say(f"assembly benchmark: {mesh.t.shape[1]} triangles, {basis.N} dofs ...")
        K0, r0 = asm(K_form, basis, u=basis.interpolate(u)), asm(r_form, basis, u=basis.interpolate(u))
        r1, K1 = fast.residual_and_tangent(u)
        free = np.setdiff1d(np.arange(basis.N), basis.get_dofs("left").flatten())
        Kc = K1[free][:, free].tocsc()
        ms = {key: median_time(fn, repeats) for key, fn in (
            ("ref_tangent_ms", lambda: asm(K_form, basis, u=basis.interpolate(u))),
            ("ref_residual_ms", lambda: asm(r_form, basis, u=basis.interpolate(u))),
            ("fast_tangent_ms", lambda: fast.tangent(u)), ("fast_residual_ms", lambda: fast.residual(u)),
            ("fast_both_ms", lambda: fast.residual_and_tangent(u)),
            ("splu_colamd_ms", lambda: spla.splu(Kc, permc_spec="COLAMD")),
            ("splu_mmd_ms", lambda: spla.splu(Kc, permc_spec="MMD_AT_PLUS_A")))}
        row = {"triangles": int(mesh.t.shape[1]), "nodes": int(mesh.p.shape[1]), "dofs": int(basis.N),
               "nnz": int(fast.nnz), **ms, "speedup_tangent": ms["ref_tangent_ms"] / ms["fast_tangent_ms"],
               "speedup": (ms["ref_tangent_ms"] + ms["ref_residual_ms"]) / ms["fast_both_ms"], "setup_ms": setup_ms,
               "rel_diff_tangent": float(spla.norm(K1 - K0) / spla.norm(K0)),
               "rel_diff_residual": float(np.linalg.norm(r1 - r0) / np.linalg.norm(r0))}
        rows.append(row)
        say(f"  reference K {row['ref_tangent_ms']:.1f} ms, fast K {row['fast_tangent_ms']:.2f} ms "
            f"({row['speedup_tangent']:.0f}x); SuperLU COLAMD {row['splu_colamd_ms']:.1f} ms, "
            f"MMD_AT_PLUS_A {row['splu_mmd_ms']:.1f} ms")

    say(format_table(rows))
    write_record(out, "assembly", {
        "benchmark": "assembly",
        "description": "Per Newton iteration, 2D P1 plane-strain hyperelasticity on the unit square: scikit-fem forms "
                       "(tissuefem.engine.forms) versus tissuefem.engine.assembly.P1Assembler; SuperLU factorization "
                       "of the tangent with the left edge fixed. Times in ms, medians after one warm-up.",
        "settings": {"sizes": sizes, "repeats": repeats, "material": repr(material)},
        "machine": machine, "rows": rows}, rows, say)
    return rows
