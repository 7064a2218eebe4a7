"""Hostile input: every bad input is a ValueError naming the field or argument, nothing crashes, nothing is lost.

One section per class of defect found by an adversarial run over the public API:

1. mesh files (a reader that ends the process, 3D / quad / lines-only / non-planar files);
2. resource limits (triangle counts, grids, aspect ratios), checked before allocating;
3. finite values that overflow later (ranges for every numeric field);
4. deeply nested TOML/JSON;
5. ``Scene.save`` -> ``Scene.load`` for arbitrary text;
6. wrong types (scene fields, the material API's F);
7. mesh validity (``meshes.check_mesh``);
8. the corotated model at subnormal F;
9. the ``scene`` command: one line on stderr, exit status 2.
"""

from __future__ import annotations

import copy
import json
import math
import os
import subprocess
import sys
import tempfile
import warnings
from pathlib import Path

import meshio
import numpy as np
import pytest
import skfem
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from tissuefem.engine import meshes
from tissuefem.engine.materials import MATERIALS, Corotated, FiberReinforced, NeoHookean, cofactor, det2
from tissuefem.engine.meshes import MAX_TRIANGLES, check_mesh, mesh_with_about, rectangle
from tissuefem.engine.parameters import check_count, check_lame, check_real, lame_parameters
from tissuefem.surgery import scene as scene_module
from tissuefem.surgery.scene import EXAMPLE_TOML, Scene, read_mesh
from tissuefem.surgery.simulation import Simulation

from helpers import fd_tangent

HYPOTHESIS = settings(max_examples=60, deadline=None, derandomize=True,
                      suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])

MATERIAL = {"model": "stable-neo-hookean", "youngs_modulus": 1000.0, "poisson_ratio": 0.3}


def plain_scene():
    """A scene without points (handles by boundary name): changing its domain cannot move anything out of reach."""
    return {"name": "plain", "domain": {"shape": "rectangle", "width": 2.0, "height": 1.0, "triangles": 40},
            "material": dict(MATERIAL), "effects": {"handles": [{"name": "fixed", "region": "left"}]},
            "solver": {"budget": 1.0}}


def full_scene():
    """A 2 x 1 sheet with every effect."""
    return {
        "name": "full", "description": "every effect",
        "domain": {"shape": "rectangle", "width": 2.0, "height": 1.0, "triangles": 40},
        "material": dict(MATERIAL, density=1.0),
        "effects": {
            "inertia": {"time_step": 0.02, "mass": "lumped"},
            "gravity": {"acceleration": [0.0, -9.81]},
            "fibers": {"stiffness": 10.0, "direction": [1.0, 1.0]},
            "inversion": {"method": "projected"},
            "handles": [{"name": "fixed", "region": "left"},
                        {"name": "pull", "region": {"box": [1.9, 0.0, 2.0, 1.0]}, "target": [0.1, 0.0]},
                        {"name": "pin", "region": {"near": [1.0, 0.5], "radius": 0.2}},
                        {"name": "nodes", "region": {"nodes": [0, 1]}}],
            "tractions": [{"boundary": "top", "traction": [0.0, 1.0]}],
            "probes": [{"center": [1.0, 1.2], "radius": 0.1, "stiffness": 1e4}],
            "excisions": [{"polygon": [[0.5, 0.2], [1.2, 0.2], [1.2, 0.8], [0.5, 0.8]]}],
            "incisions": [{"path": [[1.4, 0.0], [1.4, 0.5]]}],
            "sutures": [{"pairs": [[[0.1, 1.0], [0.9, 1.0]]], "stiffness": 1e3, "tightness": 0.5}],
            "contact": {"stiffness": 1e3},
        },
        "solver": {"budget": 1.0, "rtol": 1e-6, "linear_solver": "reuse", "max_iterations": 20},
    }


def put(data, path, value):
    """``data`` with the field at ``path`` (keys and list indices) replaced by ``value``."""
    data = copy.deepcopy(data)
    target = data
    for key in path[:-1]:
        target = target[key]
    target[path[-1]] = value
    return data


def dotted(path) -> str:
    out = ""
    for key in path:
        out += f"[{key}]" if isinstance(key, int) else (f".{key}" if out else key)
    return out


# ---------------------------------------------------------------------------------------------------------------
# 1 and 7: mesh files and mesh validity
# ---------------------------------------------------------------------------------------------------------------

def _write_meshes(folder: Path) -> dict:
    """Bad mesh files and the phrase their refusal must contain."""
    quiet = warnings.catch_warnings()
    files = {}
    (folder / "corrupt.msh").write_text("$MeshFormat\n garbage\n")
    files["corrupt.msh"] = "could not read"
    (folder / "empty.vtk").write_text("")  # meshio reports it and calls sys.exit(1)
    files["empty.vtk"] = "could not read"
    (folder / "noise.msh").write_bytes(bytes(range(256)) * 3)
    files["noise.msh"] = "could not read"
    (folder / "unknown.xyz").write_text("1 2 3\n")
    files["unknown.xyz"] = "could not read"
    with quiet:
        warnings.simplefilter("ignore")
        cube = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1.0]])
        square = np.array([[0, 0], [1, 0], [1, 1], [0, 1.0]])
        written = {
            "flat_tetra.vtk": (meshio.Mesh(cube * [1, 1, 0], [("tetra", [[0, 1, 2, 3]])]), "zero-volume"),
            "twice_tetra.vtk": (meshio.Mesh(cube, [("triangle", [[0, 1, 2]]), ("tetra", [[0, 1, 2, 3], [0, 1, 3, 2]])]),
                                "folded"),
            "hexahedron.vtk": (meshio.Mesh(np.vstack([cube, cube + 1]), [("hexahedron", [list(range(8))])]),
                               "hexahedron"),
            "quad.vtk": (meshio.Mesh(square, [("quad", [[0, 1, 2, 3]])]), "quad"),
            "lines.vtk": (meshio.Mesh(square, [("line", [[0, 1], [1, 2]])]), "no triangles"),
            "quadratic.vtk": (meshio.Mesh(np.vstack([square, [[0.5, 0], [0.5, 0.5], [0, 0.5]]]),
                                          [("triangle6", [[0, 1, 3, 4, 5, 6]])]), "triangle6"),
            "tilted.vtk": (meshio.Mesh(np.array([[0, 0, 0], [1, 0, 0.5], [0, 1, 0.0]]), [("triangle", [[0, 1, 2]])]),
                           "not planar"),
            "outside.vtk": (meshio.Mesh(square, [("triangle", [[0, 1, 9]])]), "outside"),
            "fin.vtk": (meshio.Mesh(np.vstack([square, [[0.5, -1.0]]]),
                                    [("triangle", [[0, 1, 2], [0, 1, 3], [0, 1, 4]])]), "shared by 3 triangles"),
            "flat.vtk": (meshio.Mesh(np.array([[0, 0], [1, 0], [2, 0.0]]), [("triangle", [[0, 1, 2]])]), "degenerate"),
            "twice.vtk": (meshio.Mesh(square, [("triangle", [[0, 1, 2], [2, 1, 0]])]), "same triangle"),
            "nan.vtk": (meshio.Mesh(np.array([[0, 0], [1, 0], [0, np.nan]]), [("triangle", [[0, 1, 2]])]),
                        "non-finite"),
            "far.vtk": (meshio.Mesh(np.array([[0, 0], [1e9, 0], [0, 1e9]]), [("triangle", [[0, 1, 2]])]),
                        "coordinate limit"),
        }
        for name, (mesh, phrase) in written.items():
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                mesh.write(str(folder / name))
            files[name] = phrase
    return files


@pytest.fixture(scope="module")
def bad_meshes(tmp_path_factory):
    folder = tmp_path_factory.mktemp("meshes")
    return folder, _write_meshes(folder)


def test_every_bad_mesh_file_is_a_value_error_naming_domain_path(bad_meshes):
    folder, files = bad_meshes
    for name, phrase in files.items():
        with pytest.raises(ValueError, match="domain.path") as err:
            read_mesh(folder / name)
        assert phrase in str(err.value), (name, str(err.value))
        assert "\n" not in str(err.value)


def test_a_reader_that_calls_sys_exit_is_caught_but_an_interrupt_is_not(bad_meshes, monkeypatch):
    folder, _ = bad_meshes
    good = folder / "good.msh"
    rectangle(2.0, 1.0, 4, 2).save(str(good))

    def exits(*args, **kwargs):
        print("the reader's own complaint")
        sys.exit(1)

    monkeypatch.setattr(meshio, "read", exits)
    with pytest.raises(ValueError, match="domain.path: could not read 'good.msh' as a mesh: the reader's own"):
        read_mesh(good)

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(meshio, "read", interrupted)
    with pytest.raises(KeyboardInterrupt):
        read_mesh(good)


def _edges(mesh, name):
    """The named boundary as a set of edges, each a sorted pair of coordinate tuples."""
    pts = mesh.p[:, mesh.facets[:, mesh.boundaries[name]]].round(12)
    return {tuple(sorted([tuple(pts[:, 0, k]), tuple(pts[:, 1, k])])) for k in range(pts.shape[2])}


@pytest.mark.parametrize("suffix", [".msh", ".vtk"])
def test_boundaries_written_by_scikit_fem_come_back_on_the_same_edges(tmp_path, suffix):
    # scikit-fem's own reader decodes its boundary flags after sorting each triangle's nodes, which puts
    # them on other edges for our counter-clockwise meshes; read_mesh decodes them in the written order
    for mesh in (rectangle(2.0, 1.0, 6, 3), meshes.fusiform_muscle(nx=10, ny=4)):
        mesh.save(str(tmp_path / f"m{suffix}"))
        back = read_mesh(tmp_path / f"m{suffix}")
        assert back.nelements == mesh.nelements and np.allclose(back.p, mesh.p)
        for name in mesh.boundaries:
            assert _edges(back, name) == _edges(mesh, name), name


def test_unused_nodes_of_a_file_are_dropped_with_a_note_and_named_groups_kept(tmp_path):
    points = np.array([[0, 0], [1, 0], [1, 1], [0, 1], [0.5, 0.5], [3, 3]], float)  # node 5: a geometry point
    mesh = meshio.Mesh(points, [("triangle", [[0, 1, 4], [1, 2, 4], [2, 3, 4], [3, 0, 4]]), ("line", [[3, 0]]),
                                ("vertex", [[5]])],
                       cell_data={"gmsh:physical": [np.full(4, 1), np.array([2]), np.array([3])],
                                  "gmsh:geometrical": [np.full(4, 1), np.array([2]), np.array([3])]},
                       field_data={"tissue": np.array([1, 2]), "left": np.array([2, 1]), "centre": np.array([3, 0])})
    mesh.write(str(tmp_path / "square.msh"), file_format="gmsh22", binary=False)
    notes = []
    back = read_mesh(tmp_path / "square.msh", notes=notes)
    assert back.nvertices == 5 and len(notes) == 1 and "dropped 1 node" in notes[0] and "[5]" in notes[0]
    assert _edges(back, "left") == {((0.0, 0.0), (0.0, 1.0))}
    # a scene naming node indices of such a file is refused (the numbers would point at other nodes)
    data = {"domain": {"shape": "file", "path": "square.msh"}, "material": dict(MATERIAL),
            "effects": {"handles": [{"region": "left"}]}}
    scene = Scene.from_dict(data, base_dir=tmp_path)
    sim = Simulation(scene)
    assert sim.mesh.nvertices == 5 and scene.notes == notes
    data["effects"]["handles"] = [{"region": {"nodes": [0, 3]}}]
    with pytest.raises(ValueError, match=r"effects.handles\[0\].region.nodes"):
        Simulation(Scene.from_dict(data, base_dir=tmp_path))


def test_a_file_domain_checks_points_and_radii_against_the_mesh_it_reads(tmp_path):
    rectangle(2.0, 1.0, 4, 2).save(str(tmp_path / "m.msh"))
    data = {"domain": {"shape": "file", "path": "m.msh", "scale": 1e-3}, "material": dict(MATERIAL),
            "effects": {"handles": [{"region": "left"}], "probes": [{"center": [10.0, 0.5], "radius": 0.5}]}}
    scene = Scene.from_dict(data, base_dir=tmp_path)  # the size is not known before the file is read
    with pytest.raises(ValueError, match=r"effects.probes\[0\].center = .*the mesh read from 'm.msh'"):
        Simulation(scene)


def test_check_mesh_names_unused_nodes_and_edges_of_three_triangles():
    m = rectangle(1.0, 1.0, 2, 2)
    p, t = check_mesh(m.p, m.t)
    assert p.dtype == np.float64 and t.dtype == np.int64 and t.shape == m.t.shape
    with pytest.raises(ValueError, match=r"mesh: nodes \[9, 10\] \(2 in all\) belong to no triangle"):
        check_mesh(np.c_[m.p, [[5.0, 6.0], [5.0, 6.0]]], m.t)
    fin_p = [[0.0, 1.0, 0.0, 0.0, 1.0], [0.0, 0.0, 1.0, -1.0, 1.0]]
    with pytest.raises(ValueError, match=r"mesh: edge \(0, 1\) is shared by 3 triangles \[0, 1, 2\]"):
        check_mesh(fin_p, [[0, 0, 0], [1, 1, 1], [2, 3, 4]])
    with pytest.raises(ValueError, match="same triangle"):
        check_mesh([[0, 1, 0], [0, 0, 1.0]], [[0, 0], [1, 2], [2, 1]])
    with pytest.raises(ValueError, match="t must be an integer array"):
        check_mesh(m.p, m.t.astype(float))
    with pytest.raises(ValueError, match=f"more than the {MAX_TRIANGLES} allowed"):
        check_mesh(m.p, np.zeros((3, MAX_TRIANGLES + 1), dtype=np.int64))
    with pytest.raises(ValueError, match="spans only"):
        check_mesh(m.p * 1e-9, m.t)


@HYPOTHESIS
@given(p=hnp.arrays(np.float64, st.tuples(st.integers(1, 3), st.integers(0, 6)),
                    elements=st.one_of(st.floats(-10, 10), st.sampled_from([math.nan, math.inf, 1e300]))),
       t=hnp.arrays(np.int64, st.tuples(st.integers(1, 4), st.integers(0, 5)), elements=st.integers(-2, 7)))
def test_check_mesh_on_junk_returns_a_mesh_or_a_value_error(p, t):
    try:
        p2, t2 = check_mesh(p, t)
    except ValueError as err:
        assert str(err).startswith("mesh")
    else:
        assert p2.shape[0] == 2 and t2.shape[0] == 3 and np.all(np.isfinite(p2))


# ---------------------------------------------------------------------------------------------------------------
# 2: resource limits, checked before anything is allocated
# ---------------------------------------------------------------------------------------------------------------

@pytest.mark.parametrize("path, value, field", [
    (("domain", "triangles"), 10**9, "domain.triangles"),
    (("domain", "triangles"), MAX_TRIANGLES + 1, "domain.triangles"),
    (("domain", "triangles"), 10**400, "domain.triangles"),
    (("domain", "width"), 1e7, "domain.width"),
    (("domain", "width"), 1e5, r"domain.width / domain.height"),
    (("domain", "height"), 1e-5, r"domain.width / domain.height"),
])
def test_scene_sizes_are_capped(path, value, field):
    with pytest.raises(ValueError, match=field):
        Scene.from_dict(put(plain_scene(), path, value))


@pytest.mark.parametrize("domain, field", [
    ({"shape": "fusiform", "nx": 10**5, "ny": 10**5}, r"domain.nx, domain.ny"),
    ({"shape": "fusiform", "nx": 10**6}, "domain.nx"),
    ({"shape": "fusiform", "ny": 0}, "domain.ny"),
    ({"shape": "fusiform", "tendon_width": 1e-5}, "domain.max_width / domain.tendon_width"),
    ({"shape": "fusiform", "length": 1e5}, "domain.length / domain.max_width"),
])
def test_fusiform_grids_are_capped(domain, field):
    data = put(plain_scene(), ("domain",), domain)
    data["effects"]["handles"][0]["region"] = "left_tendon"
    with pytest.raises(ValueError, match=field):
        Scene.from_dict(data)


@pytest.mark.parametrize("call, argument", [
    (lambda: rectangle(nx=10**6), "nx"),
    (lambda: rectangle(ny=10**6), "ny"),
    (lambda: rectangle(nx=1000, ny=1000), "nx, ny"),
    (lambda: rectangle(width=1e6, height=1e-6), "width / height"),
    (lambda: rectangle(width=1e300), "width"),
    (lambda: mesh_with_about(10**9), "n_triangles"),
    (lambda: mesh_with_about(True), "n_triangles"),
    (lambda: meshes.flap(n_triangles=10**12), "n_triangles"),
    (lambda: meshes.fusiform_muscle(nx=10**5, ny=10**5), "nx, ny"),
    (lambda: meshes.fusiform_muscle(tendon_width=1e-300), "tendon_width"),
])
def test_library_sizes_are_capped_naming_the_argument(call, argument):
    with pytest.raises(ValueError, match=argument):
        call()


@HYPOTHESIS
@given(n=st.integers(1, MAX_TRIANGLES), log_aspect=st.floats(-4.0, 4.0))
def test_the_grid_honours_the_requested_count_for_any_aspect_ratio(n, log_aspect):
    nx, ny = meshes._grid_for(n, 10.0**log_aspect, 1.0)
    count = 2 * nx * ny
    assert count <= MAX_TRIANGLES
    assert max(count / n, n / count) <= (2.0 if n == 1 else 1.5)


def test_a_strip_a_thousand_times_longer_than_wide_gets_about_the_requested_count():
    for width, height in ((1000.0, 1.0), (1.0, 1000.0)):
        mesh = mesh_with_about(800, width, height)
        assert 800 / 1.5 <= mesh.nelements <= 800 * 1.5
        assert np.isclose(meshes.signed_areas(mesh).sum(), width * height)


# ---------------------------------------------------------------------------------------------------------------
# 3 and 6: ranges and types of every field
# ---------------------------------------------------------------------------------------------------------------

@pytest.mark.parametrize("path, value, field", [
    (("material", "youngs_modulus"), 1e154, "material.youngs_modulus"),
    (("material", "youngs_modulus"), 10**400, "material.youngs_modulus"),
    (("material", "youngs_modulus"), 10**20, "material.youngs_modulus"),
    (("material", "youngs_modulus"), True, "material.youngs_modulus must be a number"),
    (("material", "youngs_modulus"), "1000", "material.youngs_modulus must be a number"),
    (("material", "poisson_ratio"), True, "material.poisson_ratio must be a number"),
    (("material", "poisson_ratio"), -1.0, "material.poisson_ratio must be > -1"),
    (("material", "poisson_ratio"), -0.9999999999999999, "material.poisson_ratio = .* too close to -1"),
    (("material", "poisson_ratio"), 0.49999999, "material.poisson_ratio = .* too close to 0.5"),
    (("material", "density"), 1e300, "material.density"),
    (("effects", "inertia", "time_step"), 1e154, "effects.inertia.time_step"),
    (("effects", "inertia", "time_step"), 1e-200, "effects.inertia.time_step"),
    (("effects", "inertia", "time_step"), math.inf, "effects.inertia.time_step must be finite"),
    (("effects", "probes", 0, "radius"), 1e154, r"effects.probes\[0\].radius"),
    (("effects", "probes", 0, "radius"), 1e-200, r"effects.probes\[0\].radius"),
    (("effects", "probes", 0, "radius"), 1e-7, r"effects.probes\[0\].radius .* domain sizes"),
    (("effects", "probes", 0, "center"), [1e5, 0.0], r"effects.probes\[0\].center .* domain sizes"),
    (("effects", "probes", 0, "stiffness"), 1e300, r"effects.probes\[0\].stiffness"),
    (("effects", "handles", 1, "target"), [1e300, 0.0], r"effects.handles\[1\].target\[0\]"),
    (("effects", "handles", 1, "target"), [1e4, 0.0], r"effects.handles\[1\].target .* displacement"),
    (("effects", "handles", 2, "region", "radius"), 1e-200, r"effects.handles\[2\].region.radius"),
    (("effects", "handles", 3, "region", "nodes"), [1.0], r"effects.handles\[3\].region.nodes\[0\] must be an int"),
    (("effects", "handles", 3, "region", "nodes"), [2.5], r"effects.handles\[3\].region.nodes\[0\]"),
    (("effects", "handles", 3, "region", "nodes"), [-1], r"effects.handles\[3\].region.nodes\[0\]"),
    (("effects", "handles", 3, "region", "nodes"), [10**7], r"effects.handles\[3\].region.nodes\[0\]"),
    (("effects", "handles", 3, "region", "nodes"), [True], r"effects.handles\[3\].region.nodes\[0\]"),
    (("effects", "gravity", "acceleration"), [0.0, -1e300], r"effects.gravity.acceleration\[1\]"),
    (("effects", "tractions", 0, "traction"), [1e300, 0.0], r"effects.tractions\[0\].traction\[0\]"),
    (("effects", "fibers", "stiffness"), 1e300, "effects.fibers.stiffness"),
    (("effects", "inversion"), {"method": "itf", "threshold": 1e-300}, "effects.inversion.threshold"),
    (("effects", "sutures", 0, "stiffness"), 0.0, r"effects.sutures\[0\].stiffness must be > 0"),
    (("effects", "sutures", 0, "tightness"), 1.5, r"effects.sutures\[0\].tightness"),
    (("effects", "contact", "distance"), -0.01, r"effects.contact.distance"),
    (("effects", "contact", "stiffness"), float("inf"), r"effects.contact.stiffness"),
    (("effects", "contact", "stiffness"), 0.0, r"effects.contact.stiffness"),
    (("effects", "contact", "skin"), 1.0, r"effects.contact: unknown key"),
    (("effects", "contact"), 0.5, r"effects.contact must be a table"),
    (("effects", "excisions", 0, "polygon"), [[0, 0]] * 10_001, r"effects.excisions\[0\].polygon"),
    (("effects", "handles"), [{"region": "left"}] * 1001, "effects.handles: at most 1000"),
    (("effects",), 0, "effects must be a table"),
    (("effects",), [], "effects must be a table"),
    (("solver",), 3, "solver must be a table"),
    (("solver",), None, "solver must be a table"),
    (("solver", "rtol"), math.nan, "solver.rtol must be finite"),
    (("solver", "rtol"), -1.0, "solver.rtol must be > 0"),
    (("solver", "rtol"), 1e-300, "solver.rtol"),
    (("solver", "max_iterations"), -1, "solver.max_iterations"),
    (("solver", "max_iterations"), 20.0, "solver.max_iterations must be an integer"),
    (("solver", "max_iterations"), 10**6, "solver.max_iterations"),
    (("solver", "budget"), 1e300, "solver.budget"),
    (("name",), "a\ud800b", "name contains a lone surrogate"),
    (("description",), "x" * 10_001, "description must be at most"),
])
def test_out_of_range_and_wrong_types_name_the_field(path, value, field):
    with pytest.raises(ValueError, match=field):
        Scene.from_dict(put(full_scene(), path, value))


def test_the_full_scene_is_valid_and_builds():
    scene = Scene.from_dict(full_scene())
    assert set(scene.effects) == set(scene_module.EFFECTS)
    assert Simulation(scene, clock=lambda: 0.0).frame().converged  # a fake clock: no budget miss under load


@pytest.mark.parametrize("call, name", [
    (lambda: lame_parameters(True, 0.3), "E"),
    (lambda: lame_parameters("1000", 0.3), "E"),
    (lambda: lame_parameters(10**400, 0.3), "E"),
    (lambda: lame_parameters(1e154, 0.3), "E"),
    (lambda: lame_parameters(1000.0, True), "nu"),
    (lambda: lame_parameters(1000.0, 1j), "nu"),
    (lambda: lame_parameters(1.0, -0.9999999999999999), "nu .* too close to -1"),
    (lambda: NeoHookean.from_young(1e12, 0.4999999999), "nu .* too close to 0.5"),
    (lambda: check_lame(1.0, 1e31), "mu"),
    (lambda: check_lame(np.inf, 1.0), "lam"),
    (lambda: check_real("x", np.array([1.0, 2.0])), "x"),
    (lambda: check_count("count", 3.0), "count"),
    (lambda: check_count("count", np.True_), "count"),
    (lambda: NeoHookean.from_young("1000", 0.3), "E"),
    (lambda: FiberReinforced(NeoHookean(1.0, 1.0), True, [1.0, 0.0]), "stiffness"),
    (lambda: FiberReinforced(NeoHookean(1.0, 1.0), 1.0, [1.0 + 1j, 0.0]), "fibers"),
])
def test_the_parameter_checks_refuse_bool_strings_complex_and_huge_numbers(call, name):
    with pytest.raises(ValueError, match=name):
        call()


def _junk():
    scalars = st.one_of(st.none(), st.booleans(), st.integers(), st.integers(-(10**400), 10**400),
                        st.floats(allow_nan=True, allow_infinity=True), st.floats(-1e3, 1e3),
                        st.text(max_size=8), st.just("1000"))
    return st.recursive(scalars, lambda inner: st.one_of(st.lists(inner, max_size=4),
                                                         st.dictionaries(st.text(max_size=6), inner, max_size=3)),
                        max_leaves=10)


_FULL_FIELDS = [
    ("name",), ("description",), ("material",), ("material", "model"), ("material", "youngs_modulus"),
    ("material", "poisson_ratio"), ("material", "density"), ("effects",), ("effects", "inertia"),
    ("effects", "inertia", "time_step"), ("effects", "inertia", "mass"), ("effects", "gravity", "acceleration"),
    ("effects", "fibers", "stiffness"), ("effects", "fibers", "direction"), ("effects", "inversion", "method"),
    ("effects", "handles"), ("effects", "handles", 0), ("effects", "handles", 1, "region"),
    ("effects", "handles", 1, "target"), ("effects", "handles", 0, "name"), ("effects", "handles", 3, "region"),
    ("effects", "tractions", 0, "traction"), ("effects", "tractions", 0, "boundary"),
    ("effects", "probes", 0, "center"), ("effects", "probes", 0, "radius"), ("effects", "probes", 0, "stiffness"),
    ("effects", "excisions", 0, "polygon"), ("effects", "incisions", 0, "path"), ("effects", "sutures", 0, "pairs"),
    ("effects", "sutures", 0, "tightness"), ("solver",), ("solver", "budget"), ("solver", "rtol"),
    ("solver", "max_iterations"), ("solver", "linear_solver"),
]
_DOMAIN_FIELDS = [("domain",), ("domain", "shape"), ("domain", "width"), ("domain", "height"),
                  ("domain", "triangles")]


def _valid_or_named(data, path):
    try:
        scene = Scene.from_dict(data)
    except ValueError as err:
        message = str(err)
        assert dotted(path) in message or (path[0] == "domain" and "domain" in message), message
        assert "\n" not in message and len(message) < 2000
    else:  # accepted: then it is computable as far as the scene goes, and it round-trips
        assert Scene.from_toml(scene.to_toml()) == scene and Scene.from_json(scene.to_json()) == scene


@HYPOTHESIS
@given(field=st.sampled_from(_FULL_FIELDS), value=_junk())
def test_junk_in_any_field_is_refused_naming_that_field_or_accepted(field, value):
    _valid_or_named(put(full_scene(), field, value), field)


@HYPOTHESIS
@given(field=st.sampled_from(_DOMAIN_FIELDS), value=_junk())
def test_junk_in_the_domain_is_refused_naming_the_field_or_accepted(field, value):
    _valid_or_named(put(plain_scene(), field, value), field)


@HYPOTHESIS
@given(value=st.one_of(st.integers(-5, MAX_TRIANGLES + 5), st.floats(-10.0, 2e5)), key=st.sampled_from(["nx", "ny"]))
def test_fusiform_counts_are_true_integers_in_range(value, key):
    data = put(plain_scene(), ("domain",), {"shape": "fusiform", key: value})
    data["effects"]["handles"][0]["region"] = "left_tendon"
    try:
        scene = Scene.from_dict(data)
    except ValueError as err:
        assert f"domain.{key}" in str(err)
    else:
        assert isinstance(scene.domain[key], int) and 2 * scene.domain["nx"] * scene.domain["ny"] <= MAX_TRIANGLES


@pytest.mark.parametrize("reader", [Scene.from_toml, Scene.from_json])
@pytest.mark.parametrize("text", [None, 3, ["a"], b"\xff\xfe"])
def test_parsers_refuse_what_is_not_text(reader, text):
    with pytest.raises(ValueError, match="scene"):
        reader(text)


@pytest.mark.parametrize("text", ["x = 1" + "0" * 5000, 'name = "a\\ud800"', "name = 'a'\nname = 'b'"])
def test_invalid_toml_is_one_value_error(text):
    with pytest.raises(ValueError, match="scene: not valid TOML"):
        Scene.from_toml(text)


# ---------------------------------------------------------------------------------------------------------------
# 4: nesting
# ---------------------------------------------------------------------------------------------------------------

@pytest.mark.parametrize("text, reader", [
    ("[" * 100_000 + "]" * 100_000, Scene.from_json),
    ('{"a": ' * 50_000 + "1" + "}" * 50_000, Scene.from_json),
    ("a = " + "[" * 100_000 + "]" * 100_000, Scene.from_toml),
    ("a = " + "{b = " * 50_000 + "1" + "}" * 50_000, Scene.from_toml),
    ('name = "x"\n[material]\nmodel = ' + "[" * 17 + "]" * 17, Scene.from_toml),
])
def test_deep_nesting_is_refused_before_parsing(text, reader):
    with pytest.raises(ValueError, match="nests deeper than 16 levels") as refused:
        reader(text)
    assert refused.value.field == "scene"


def test_deep_nesting_without_brackets_or_from_python_is_refused():
    with pytest.raises(ValueError, match="nested deeper than 16"):
        Scene.from_toml("[" + ".".join(["a"] * 20_000) + "]\nx = 1")
    deep = {}
    inner = deep
    for _ in range(100_000):
        inner["x"] = {}
        inner = inner["x"]
    with pytest.raises(ValueError, match="nested deeper than 16"):
        Scene.from_dict({"effects": deep, "material": dict(MATERIAL)})
    cyclic = {"material": dict(MATERIAL)}
    cyclic["effects"] = {"handles": [cyclic]}
    with pytest.raises(ValueError, match="effects.handles"):
        Scene.from_dict(cyclic)


def test_brackets_inside_strings_and_comments_do_not_count():
    name = "[" * 40 + "{" * 40
    text = f'name = "{name}"  # {"[" * 40}\n' + EXAMPLE_TOML.split("\n", 1)[1] + f"# {'{' * 40}\n"
    assert Scene.from_toml(text).name == name
    assert Scene.from_json(Scene.from_toml(text).to_json()).name == name


_NESTED = st.recursive(st.one_of(st.integers(-3, 3), st.text(alphabet="[]{}\"'#\\ab", max_size=5)),
                       lambda inner: st.one_of(st.lists(inner, max_size=3),
                                               st.dictionaries(st.sampled_from("abc"), inner, max_size=2)),
                       max_leaves=30)


@HYPOTHESIS
@given(value=_NESTED, depth=st.integers(0, 40), field=st.sampled_from(_FULL_FIELDS[:20]))
def test_nested_structures_anywhere_are_a_value_error_or_a_scene(value, depth, field):
    for _ in range(depth):
        value = [value]
    data = put(full_scene(), field, value)
    for text, reader in ((json.dumps(data), Scene.from_json), (None, None)):
        try:
            (reader(text) if reader else Scene.from_dict(data))
        except ValueError:
            pass


# ---------------------------------------------------------------------------------------------------------------
# 5: save -> load for arbitrary text
# ---------------------------------------------------------------------------------------------------------------

_TEXT = st.text(st.characters(blacklist_categories=("Cs",)), max_size=40)


@HYPOTHESIS
@given(name=_TEXT, description=_TEXT, handle=_TEXT, boundary=_TEXT.filter(bool),
       path=_TEXT.filter(lambda s: s and "\0" not in s))
def test_any_text_round_trips_through_save_and_load(name, description, handle, boundary, path):
    data = full_scene()
    data.update(name=name, description=description)
    data["effects"]["handles"][0]["name"] = handle
    data["effects"]["tractions"][0]["boundary"] = boundary
    scene = Scene.from_dict(data)
    file_scene = Scene.from_dict({**plain_scene(), "domain": {"shape": "file", "path": path}, "name": name})
    with tempfile.TemporaryDirectory() as folder:
        for s in (scene, file_scene):
            for suffix in (".toml", ".json"):
                target = Path(folder) / f"scene{suffix}"
                s.save(target)
                assert Scene.load(target) == s


@pytest.mark.parametrize("text", ["\U0001F600 emoji", 'quote " and \\ backslash', "tab\tnew\nline\r\x00\x1f\x7f",
                                  "\u2028 \ufeff \U0010FFFF", "'''\"\"\"", "é" * 300])
def test_awkward_names_round_trip(tmp_path, text):
    scene = Scene.from_dict({**full_scene(), "name": text, "description": text})
    for suffix in (".toml", ".json"):
        scene.save(tmp_path / f"s{suffix}")
        assert Scene.load(tmp_path / f"s{suffix}") == scene


def test_a_failed_save_changes_nothing(tmp_path, monkeypatch):
    target = tmp_path / "s.toml"
    target.write_text("old contents")
    scene = Scene.from_dict(full_scene())
    monkeypatch.setattr(Scene, "to_toml", lambda self: "name = 'not the same scene'\n[material]\n"
                                                       "model = 'linear'\nyoungs_modulus = 1.0\npoisson_ratio = 0.0\n")
    with pytest.raises(ValueError, match="would not read back"):
        scene.save(target)
    assert target.read_text() == "old contents" and sorted(p.name for p in tmp_path.iterdir()) == ["s.toml"]
    with pytest.raises(ValueError, match="cannot be written"):
        Scene.from_dict(full_scene()).save(tmp_path / "missing" / "s.json")


# ---------------------------------------------------------------------------------------------------------------
# 6: the material API's F
# ---------------------------------------------------------------------------------------------------------------

_BAD_F = st.one_of(
    hnp.arrays(st.sampled_from([np.complex128, np.bool_, np.dtype("U3"), np.object_]), st.just((2, 2, 3))),
    hnp.arrays(np.float64, hnp.array_shapes(min_dims=0, max_dims=4, max_side=3)).filter(
        lambda a: a.ndim < 2 or a.shape[:2] not in ((2, 2), (3, 3))),  # 3x3: a tetrahedron's F
    st.just([[1.0, 2.0], [3.0]]), st.just([[1.0, "a"], [0.0, 1.0]]), st.just("F"), st.none(),
    st.just([[1.0 + 1e-3j, 0.0], [0.0, 1.0]]),
)


@HYPOTHESIS
@given(F=_BAD_F, name=st.sampled_from(sorted(MATERIALS)), what=st.sampled_from(["energy", "stress", "tangent"]))
def test_bad_F_is_a_value_error_naming_F(F, name, what):
    m = MATERIALS[name](1.0, 1.0)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # nothing is silently cast (complex -> real used to warn and truncate)
        with pytest.raises(ValueError, match="F must"):
            getattr(m, what)(F)
    with pytest.raises(ValueError, match="F must"):
        det2(F)


def test_integer_F_is_still_accepted():
    m = NeoHookean(1.0, 1.0)
    assert m.energy(np.eye(2, dtype=np.int32)) == 0.0
    assert np.allclose(cofactor([[1, 2], [3, 4]]), [[4, -3], [-2, 1]])


# ---------------------------------------------------------------------------------------------------------------
# 8: the corotated model at subnormal F
# ---------------------------------------------------------------------------------------------------------------

LAM, MU = 1.7, 0.6


def _G(seed=0, n=20):
    rng = np.random.default_rng(seed)
    return rng.normal(size=(2, 2, n))


@pytest.mark.parametrize("scale", [1e-160, 1e-200, 1e-300, 1e-310, 5e-324, 0.0])
def test_corotated_is_finite_and_consistent_for_collapsed_F(scale):
    m = Corotated(LAM, MU)
    F = scale * _G()
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no overflow, no invalid value
        psi, P, A = m.energy(F), m.stress(F), m.tangent(F)
    assert np.all(np.isfinite(psi)) and np.all(np.isfinite(P)) and np.all(np.isfinite(A))
    # below rho = 1.5e-154 the rotation is I: the model is mu |F - I|^2 + lam/2 (J - 1)^2, whose stress and
    # tangent at F ~ 0 are -2 mu I and 2 mu I4 - lam H (H: the derivative of cof F)
    eye = np.eye(2)[:, :, None]
    assert np.allclose(psi, 2 * MU + LAM / 2) and np.allclose(P, -2 * MU * eye)
    H = np.einsum("ik,jl->ijkl", [[0, 1], [-1, 0]], [[0, 1], [-1, 0]])
    I4 = np.einsum("ik,jl->ijkl", np.eye(2), np.eye(2))
    assert np.allclose(A, (2 * MU * I4 - LAM * H)[..., None])


@pytest.mark.parametrize("scale", [1.0, 1e-3, 1e-50, 1e-100, 1e-150])
def test_corotated_tangent_is_the_derivative_of_its_stress_down_to_tiny_F(scale):
    # the tangent grows like 1/rho as F shrinks; with a step relative to F the finite differences follow it
    m = Corotated(LAM, MU)
    F = scale * _G(1)
    A = m.tangent(F)
    fd = fd_tangent(m, F, 1e-6 * scale)
    assert np.all(np.isfinite(A))
    err = np.max(np.abs(A - fd), axis=(0, 1, 2, 3)) / np.max(np.abs(A), axis=(0, 1, 2, 3))
    assert err.max() < 1e-6


def test_corotated_energy_is_continuous_across_the_collapsed_ball():
    m = Corotated(LAM, MU)
    G = _G(2)
    rho = np.hypot(G[0, 0] + G[1, 1], G[1, 0] - G[0, 1])
    inside, outside = m.energy(G / rho * 1.4e-154), m.energy(G / rho * 1.6e-154)
    assert np.allclose(inside, outside, rtol=1e-15, atol=0)


# ---------------------------------------------------------------------------------------------------------------
# 9: the scene command
# ---------------------------------------------------------------------------------------------------------------

def _bad_scene_files(folder: Path, bad_meshes) -> list[Path]:
    mesh_folder, _ = bad_meshes
    files = []

    def scene_file(name, text, binary=False):
        path = folder / name
        path.write_bytes(text) if binary else path.write_text(text, encoding="utf-8")
        files.append(path)

    scene_file("not_toml.toml", "[domain\nshape = ")
    scene_file("not_json.json", "{'single quotes': 1}")
    scene_file("latin1.toml", 'name = "caf\xe9"'.encode("latin-1"), binary=True)
    scene_file("deep.json", "[" * 200_000 + "]" * 200_000)
    scene_file("deep.toml", "a = " + "[" * 200_000 + "]" * 200_000)
    scene_file("invalid.toml", EXAMPLE_TOML.replace("youngs_modulus = 1000.0", "youngs_modulus = 1e154"))
    scene_file("huge_int.toml", EXAMPLE_TOML.replace("triangles = 800", "triangles = 1" + "0" * 400))
    for mesh in ("empty.vtk", "flat_tetra.vtk", "corrupt.msh", "tilted.vtk"):
        scene_file(f"mesh_{mesh}.toml", f'[domain]\nshape = "file"\npath = "{(mesh_folder / mesh).as_posix()}"\n'
                                        '[material]\nmodel = "linear"\nyoungs_modulus = 1.0\npoisson_ratio = 0.3\n'
                                        '[[effects.handles]]\nregion = "left"\n')
    files.append(folder / "missing.toml")
    (folder / "folder.json").mkdir()
    files.append(folder / "folder.json")
    files.append(folder / "scene.yaml")
    return files


def test_the_scene_command_answers_every_bad_file_with_one_line_and_status_2(tmp_path, bad_meshes):
    env = dict(os.environ, PYTHONWARNINGS="default")
    for path in _bad_scene_files(tmp_path, bad_meshes):
        done = subprocess.run([sys.executable, "-m", "tissuefem", "scene", str(path), "--check"], capture_output=True,
                              text=True, env=env, timeout=120)
        lines = done.stderr.splitlines()
        assert done.returncode == 2, (path.name, done.returncode, done.stderr[-500:])
        assert len(lines) == 1 and "Traceback" not in done.stderr, (path.name, done.stderr[-500:])
        assert done.stdout == "", (path.name, done.stdout)


def test_the_scene_command_prints_the_note_of_a_file_with_unused_nodes(tmp_path, capsys):
    from tissuefem.workbook.cli import main

    mesh = rectangle(2.0, 1.0, 4, 2)
    p = np.c_[mesh.p, [[9.0], [9.0]]]
    skfem.MeshTri(p, mesh.t, sort_t=False).save(str(tmp_path / "m.vtk"))
    (tmp_path / "s.toml").write_text('[domain]\nshape = "file"\npath = "m.vtk"\n[material]\nmodel = "linear"\n'
                                     'youngs_modulus = 1.0\npoisson_ratio = 0.3\n[[effects.handles]]\n'
                                     'region = { box = [0.0, 0.0, 0.0, 1.0] }\n')
    assert main(["scene", str(tmp_path / "s.toml"), "--check"]) == 0
    out = capsys.readouterr().out
    assert "16 triangles" in out and "note: domain.path: 'm.vtk': dropped 1 node(s)" in out
