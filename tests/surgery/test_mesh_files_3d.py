"""Mesh files of tetrahedra: read into a MeshTet through meshio, checked like a 2D file (inverted, degenerate and
folded tetrahedra, unused nodes, sizes), every refusal a ParameterError naming ``domain.path`` and the file."""

import contextlib
import io
import subprocess
import sys
import warnings
from pathlib import Path

import meshio
import numpy as np
import pytest
import skfem
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from skfem.io.meshio import to_file

from tissuefem import Scene, Simulation
from tissuefem.engine.meshes import box, check_mesh, signed_volumes
from tissuefem.engine.parameters import ParameterError
from tissuefem.surgery import scene as scene_module
from tissuefem.surgery.scene import read_mesh

SETTINGS = settings(max_examples=120, deadline=None, derandomize=True, database=None,
                    suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])

BOX = box(2.0, 1.0, 1.0, 2, 1, 1)  # 12 nodes, 12 right-handed tetrahedra
MATERIAL = {"model": "stable-neo-hookean", "youngs_modulus": 1000.0, "poisson_ratio": 0.3}


def write(path, points, cells, **kwargs):
    with warnings.catch_warnings(), contextlib.redirect_stdout(io.StringIO()), \
            contextlib.redirect_stderr(io.StringIO()):
        warnings.simplefilter("ignore")
        meshio.write(str(path), meshio.Mesh(points, cells), **kwargs)
    return path


def refused(path, match, **kwargs):
    with pytest.raises(ParameterError, match=match) as err:
        read_mesh(path, **kwargs)
    assert err.value.field == "domain.path" and path.name in str(err.value)
    assert str(path.parent) not in str(err.value) and "\n" not in str(err.value)
    return str(err.value)


@pytest.mark.parametrize("suffix, file_format", [(".vtu", None), (".vtk", None), (".msh", "gmsh22"),
                                                 (".msh", "gmsh")])
def test_a_file_of_tetrahedra_reads_as_the_same_meshtet(tmp_path, suffix, file_format):
    path = write(tmp_path / f"box{suffix}", BOX.p.T, [("tetra", BOX.t.T)], file_format=file_format)
    notes = []
    mesh = read_mesh(path, 2.0, notes=notes)
    assert isinstance(mesh, skfem.MeshTet) and notes == []
    assert np.allclose(mesh.p, 2.0 * BOX.p) and np.array_equal(mesh.t, BOX.t)
    assert np.all(signed_volumes(mesh) > 0) and np.isclose(signed_volumes(mesh).sum(), 16.0)
    check_mesh(mesh.p, mesh.t)


def test_a_file_with_its_surface_triangles_takes_the_tetrahedra_and_names_the_groups(tmp_path):
    left = BOX.facets[:, BOX.boundaries["left"]]
    path = tmp_path / "box.msh"
    mesh = meshio.Mesh(BOX.p.T, [("tetra", BOX.t.T), ("triangle", left.T)],
                       cell_data={"gmsh:physical": [np.full(BOX.nelements, 2), np.full(left.shape[1], 1)],
                                  "gmsh:geometrical": [np.full(BOX.nelements, 1), np.full(left.shape[1], 1)]},
                       field_data={"fixed": np.array([1, 2]), "body": np.array([2, 3])})
    with contextlib.redirect_stdout(io.StringIO()), warnings.catch_warnings():
        warnings.simplefilter("ignore")
        mesh.write(str(path), file_format="gmsh22")
    back = read_mesh(path)
    assert back.nelements == BOX.nelements
    assert np.array_equal(np.unique(back.facets[:, back.boundaries["fixed"]]), np.unique(left))


def test_boundaries_scikit_fem_wrote_come_back_on_the_same_faces(tmp_path):
    path = tmp_path / "box.vtu"
    with contextlib.redirect_stdout(io.StringIO()), warnings.catch_warnings():
        warnings.simplefilter("ignore")
        to_file(BOX, str(path))
    back = read_mesh(path)
    for name in ("left", "right", "top", "front"):
        assert np.array_equal(np.unique(back.facets[:, back.boundaries[name]]),
                              np.unique(BOX.facets[:, BOX.boundaries[name]])), name


def test_left_handed_tetrahedra_are_reoriented_with_a_note(tmp_path):
    t = BOX.t.T.copy()
    t[::2] = t[::2][:, [0, 2, 1, 3]]  # every other tetrahedron written left-handed (a sorted file is like that)
    path = write(tmp_path / "mixed.vtu", BOX.p.T, [("tetra", t)])
    notes = []
    mesh = read_mesh(path, notes=notes)
    assert np.all(signed_volumes(mesh) > 0) and np.isclose(signed_volumes(mesh).sum(), 2.0)
    assert len(notes) == 1 and "6 tetrahedra" in notes[0] and "reoriented" in notes[0] and "mixed.vtu" in notes[0]


def test_an_unused_node_is_dropped_with_a_note_and_its_scene_refuses_node_indices(tmp_path):
    points = np.vstack([BOX.p.T, [[5.0, 5.0, 5.0]]])
    path = write(tmp_path / "extra.vtu", points, [("tetra", BOX.t.T)])
    notes = []
    assert read_mesh(path, notes=notes).nvertices == BOX.nvertices
    assert len(notes) == 1 and "no tetrahedron" in notes[0] and "[12]" in notes[0]
    data = {"domain": {"shape": "file", "path": "extra.vtu"}, "material": MATERIAL,
            "effects": {"inertia": {}, "handles": [{"name": "h", "region": {"nodes": [0]}}]}}
    with pytest.raises(ParameterError, match=r"effects.handles\[0\].region.nodes"):
        Simulation(Scene.from_dict(data, base_dir=tmp_path))


@pytest.mark.parametrize("change, match", [
    ("degenerate", "zero-volume"),
    ("folded", "folded tetrahedra"),
    ("duplicate", "folded tetrahedra|three or more"),
    ("huge", "coordinate limit"),
    ("nan", "non-finite"),
    ("tiny", "spans only"),
    ("out of range", "outside"),
    ("flat points", "points of shape|zero-volume"),
    ("hexahedron", "neither 3-node triangles nor 4-node tetrahedra"),
    ("nothing", "no triangles and no tetrahedra"),
])
def test_a_bad_file_of_tetrahedra_is_refused_naming_the_file_and_the_problem(tmp_path, change, match):
    points, t = BOX.p.T.copy(), BOX.t.T.copy()
    cells = [("tetra", t)]
    if change == "degenerate":
        points[t[0, 3]] = points[t[0, :3]].mean(axis=0)  # the fourth vertex in the plane of the other three
        cells = [("tetra", t[:1])]
    elif change == "folded":
        a, b, c, d = t[0]
        e = points[d] + 0.1 * (points[a] + points[b] + points[c] - 3 * points[d]) / 3  # beside d, same side
        points = np.vstack([BOX.p.T, e])
        cells = [("tetra", np.array([[a, b, c, d], [a, c, b, BOX.nvertices]]))]  # right-handed, overlapping
    elif change == "duplicate":
        cells = [("tetra", np.vstack([t, t[:1]]))]
    elif change == "huge":
        points[0, 0] = 1e300
    elif change == "nan":
        points[3, 1] = np.nan
    elif change == "tiny":
        points *= 1e-9
    elif change == "out of range":
        t[0, 2] = 99
    elif change == "flat points":
        points = points[:, :2]
    elif change == "hexahedron":
        cells.append(("hexahedron", np.arange(8)[None, :]))
    elif change == "nothing":
        cells = [("line", np.array([[0, 1]]))]
    path = write(tmp_path / "bad.vtu", points, cells)
    refused(path, match)


def test_too_many_tetrahedra_are_refused_before_they_are_checked(tmp_path, monkeypatch):
    path = write(tmp_path / "box.vtu", BOX.p.T, [("tetra", BOX.t.T)])
    monkeypatch.setattr(scene_module, "MAX_TRIANGLES", 10)
    refused(path, "holds 12 tetrahedra, more than 10")


# --- scenes with a file of tetrahedra -----------------------------------------------------------------------

def test_a_scene_with_a_file_of_tetrahedra_runs_with_3d_defaults(tmp_path):
    write(tmp_path / "box.vtu", BOX.p.T, [("tetra", BOX.t.T)])
    scene = Scene.from_dict({"domain": {"shape": "file", "path": "box.vtu"}, "material": MATERIAL,
                             "effects": {"inertia": {}, "gravity": {},
                                         "handles": [{"name": "fixed", "region": {"box": [0, 0, 0, 0, 1, 1]}}]}},
                            base_dir=tmp_path)
    assert scene.dim is None and "target" not in scene.effects["handles"][0]
    assert "acceleration" not in scene.effects["gravity"]
    assert Scene.from_toml(scene.to_toml(), base_dir=tmp_path) == scene
    sim = Simulation(scene, clock=lambda: 0.0)
    sim.run(2)
    u = sim.u.reshape(-1, 3).T
    assert np.all(np.isfinite(u)) and np.allclose(u[:, sim.handles["fixed"].nodes], 0.0)
    assert u[1].mean() < 0  # it falls along -y


@pytest.mark.parametrize("effects, field", [
    ({"incisions": [{"path": [[0.5, 1.1], [0.5, 0.5]]}]}, "effects.incisions"),
    ({"contact": {}}, "effects.contact"),
    ({"gravity": {"acceleration": [0.0, -9.81]}}, "effects.gravity.acceleration"),
    ({"handles": [{"name": "h", "region": "left", "target": [0.1, 0.0]}]}, r"effects.handles\[0\].target"),
    ({"handles": [{"name": "h", "region": {"box": [0, 0, 0, 1]}}]}, r"effects.handles\[0\].region.box"),
])
def test_a_scene_with_a_file_of_tetrahedra_refuses_what_is_2d_naming_the_file(tmp_path, effects, field):
    write(tmp_path / "box.vtu", BOX.p.T, [("tetra", BOX.t.T)])
    effects = {"inertia": {}, "handles": [{"name": "fixed", "region": {"box": [0, 0, 0, 0, 1, 1]}}]} | effects
    scene = Scene.from_dict({"domain": {"shape": "file", "path": "box.vtu"}, "material": MATERIAL,
                             "effects": effects}, base_dir=tmp_path)
    with pytest.raises(ParameterError, match=field) as err:
        Simulation(scene)
    assert "box.vtu" in str(err.value)


# --- files of any content ---------------------------------------------------------------------------------

_CHANGES = ["unused node", "repeated node", "left-handed", "all left-handed", "degenerate", "NaN", "huge",
            "2D points", "triangle", "line", "vertex", "hexahedron", "out of range", "shuffled", "moved node"]


def _changed(change, points, t, cells, rng):
    """A small file's content after one change (some read with a note, most refused)."""
    i = int(rng.integers(t.shape[0]))
    if change == "unused node":
        points = np.vstack([points, [[3.0, 3.0, 3.0]]])
    elif change == "repeated node":
        points = np.vstack([points, points[t[i, 0]]])
        t[i, 0] = points.shape[0] - 1
    elif change == "left-handed":
        t[i] = t[i, [1, 0, 2, 3]]
    elif change == "all left-handed":
        t = t[:, [0, 2, 1, 3]]
    elif change == "degenerate":
        t[i, 3] = t[i, 2]
    elif change in ("NaN", "huge"):
        points[int(rng.integers(points.shape[0])), 2] = np.nan if change == "NaN" else 1e300
    elif change == "2D points":
        points = points[:, :2]
    elif change in ("triangle", "line", "vertex", "hexahedron"):
        size = {"triangle": 3, "line": 2, "vertex": 1, "hexahedron": 8}[change]
        cells.append((change, np.arange(size, dtype=np.int64)[None, :]))
    elif change == "out of range":
        t[i, 1] = points.shape[0] + 5
    elif change == "shuffled":
        t = t[rng.permutation(t.shape[0])]
    elif change == "moved node":
        points[int(rng.integers(points.shape[0]))] += rng.uniform(-1.5, 1.5, 3)
    return points, t, cells


@st.composite
def _changed_box(draw):
    rng = np.random.default_rng(draw(st.integers(0, 2**16)))
    points, t, cells = BOX.p.T.copy(), BOX.t.T.copy(), []
    last = ("2D points", "all left-handed")
    for change in sorted(draw(st.lists(st.sampled_from(_CHANGES), max_size=3, unique=True)), key=lambda c: c in last):
        points, t, cells = _changed(change, points, t, cells, rng)
    return points, [("tetra", t)] + cells


_FORMATS = st.sampled_from([(".vtk", None), (".vtu", None), (".msh", "gmsh22"), (".msh", "gmsh")])


@SETTINGS
@given(mesh=_changed_box(), form=_FORMATS, scale=st.sampled_from([1.0, 1e-3, 2.5]))
def test_any_file_of_tetrahedra_gives_a_valid_mesh_or_a_parameter_error_naming_domain_path(tmp_path, mesh, form,
                                                                                          scale):
    suffix, file_format = form
    path = tmp_path / f"m{suffix}"
    points, cells = mesh
    try:
        write(path, points, cells, file_format=file_format)
    except Exception:  # a mesh this format cannot hold: meshio's business, not ours
        return
    notes = []
    try:
        back = read_mesh(path, scale, notes=notes)
    except ParameterError as err:
        assert err.field == "domain.path" and "\n" not in str(err) and "m" + suffix in str(err), str(err)
        return
    assert isinstance(back, skfem.MeshTet)
    check_mesh(back.p, back.t)  # no unused nodes, right-handed, not folded, finite, within the limits
    assert np.all(signed_volumes(back) > 0)
    dropped = back.nvertices < len(points)
    assert sum("dropped" in n for n in notes) == dropped and len(notes) <= 2


# --- the shipped organ ------------------------------------------------------------------------------------

ROOT = Path(__file__).resolve().parents[2]
KIDNEY = ROOT / "scenes" / "kidney.toml"


def test_the_shipped_kidney_mesh_is_small_valid_and_names_its_hilum():
    path = ROOT / "scenes" / "kidney.msh"
    assert path.stat().st_size < 2**20
    notes = []
    mesh = read_mesh(path, notes=notes)
    assert isinstance(mesh, skfem.MeshTet) and 1000 <= mesh.nelements <= 10_000 and notes == []
    check_mesh(mesh.p, mesh.t)
    assert {"hilum", "capsule"} <= set(mesh.boundaries)
    hilum = np.unique(mesh.facets[:, mesh.boundaries["hilum"]])
    assert 0 < hilum.size < mesh.nvertices // 4 and np.all(mesh.p[0, hilum] > 0.2)  # the notch on the medial side


def test_the_kidney_scene_runs_from_its_file_and_from_the_command(tmp_path):
    scene = Scene.load(KIDNEY)
    assert scene.domain["shape"] == "file" and Scene.from_toml(scene.to_toml(), base_dir=KIDNEY.parent) == scene
    sim = Simulation(scene, clock=lambda: 0.0)
    reports = sim.run(3)
    assert all(r.converged for r in reports) and sim.model.dim == 3
    u = sim.u.reshape(-1, 3).T
    pole = sim.handles["lower pole"].nodes
    assert np.allclose(u[:, pole], [[0.0], [0.1], [0.3]]) and np.allclose(u[:, sim.handles["hilum"].nodes], 0.0)
    run = subprocess.run([sys.executable, "-m", "tissuefem", "scene", str(KIDNEY), "--frames", "3"], cwd=tmp_path,
                         capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stderr
    assert f"kidney: {sim.mesh.nelements} tetrahedra" in run.stdout and "state finite: True" in run.stdout
