"""Property: scene files and mesh files of any content give a scene or a mesh, or a ParameterError naming a field.

Scene texts are generated as TOML and JSON (random keys and nesting, values of every type, huge and tiny
numbers, NaN and infinities, missing sections); mesh files are written with meshio (unused and repeated
nodes, inverted and degenerate triangles, other cell types, NaN coordinates, 3D points). Whatever
``Scene.load``, the ``scene --check`` command or ``read_mesh`` answers is a result or a
:class:`~tissuefem.engine.parameters.ParameterError` whose ``field`` names the field or the argument: never another
exception. Also: the misuse of ``read_mesh``, ``Scene.load`` and ``Scene.save`` (paths of the wrong kind, a
folder, a missing folder) and a saved scene that loads back equal.
"""

import contextlib
import io
import json
import math
import warnings

import meshio
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from tissuefem.engine.meshes import check_mesh, rectangle
from tissuefem.engine.parameters import ParameterError
from tissuefem.surgery.scene import Scene, demo_scene, read_mesh
from tissuefem.workbook import cli

SETTINGS = settings(max_examples=150, deadline=None, derandomize=True, database=None,
                    suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])


# ---------------------------------------------------------------------------------------------------------------
# misuse of the functions themselves
# ---------------------------------------------------------------------------------------------------------------

@pytest.mark.parametrize("path", [None, 5, 2.5, ["m.msh"], b"m.msh", "", "a\0b.msh", object()])
def test_read_mesh_refuses_a_path_of_the_wrong_kind_by_name(path):
    with pytest.raises(ParameterError, match="path") as err:
        read_mesh(path)
    assert err.value.field == "path"


@pytest.fixture(scope="module")
def mesh_with_an_unused_node(tmp_path_factory):
    path = tmp_path_factory.mktemp("mesh") / "m.vtk"
    points = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [5.0, 5.0, 0.0]])
    meshio.write(str(path), meshio.Mesh(points, [("triangle", np.array([[0, 1, 2]]))]))
    return path


@pytest.mark.parametrize("notes", ["x", 5, (), {}, "notes"])
def test_read_mesh_refuses_notes_that_are_not_a_list_by_name(mesh_with_an_unused_node, notes):
    with pytest.raises(ParameterError, match="notes") as err:
        read_mesh(mesh_with_an_unused_node, 1.0, notes=notes)
    assert err.value.field == "notes"
    kept = []
    assert read_mesh(mesh_with_an_unused_node, 1.0, notes=kept).nvertices == 3 and len(kept) == 1


@pytest.mark.parametrize("scale", ["1", None, True, [1.0], math.nan, math.inf, -1.0, 0.0, 10**400])
def test_read_mesh_refuses_a_junk_scale_by_name(mesh_with_an_unused_node, scale):
    with pytest.raises(ParameterError, match="scale") as err:
        read_mesh(mesh_with_an_unused_node, scale)
    assert err.value.field == "scale"


@pytest.mark.parametrize("where", [None, 5, b"s.toml", "", "folder", "folder/", "missing/s.toml", "s.txt",
                                   "folder.toml", "a_file/s.toml"])
def test_load_and_save_refuse_a_junk_path_by_name(tmp_path, where):
    (tmp_path / "folder").mkdir()
    (tmp_path / "folder.toml").mkdir()
    (tmp_path / "a_file").write_text("x")
    path = str(tmp_path / where) if isinstance(where, str) and where else where
    scene = demo_scene(n_triangles=60)
    for call in (Scene.load, scene.save):
        with pytest.raises(ParameterError, match="path") as err:
            call(path)
        assert err.value.field == "path", (call, where)
    assert (tmp_path / "folder.toml").is_dir() and sorted(p.name for p in tmp_path.iterdir()) == [
        "a_file", "folder", "folder.toml"]  # nothing written, nothing left behind


@pytest.mark.parametrize("suffix", [".toml", ".json"])
def test_a_saved_scene_loads_back_equal(tmp_path, suffix):
    for scene in (demo_scene(n_triangles=60), demo_scene(n_triangles=200, dynamic=False)):
        scene.save(tmp_path / f"s{suffix}")
        back = Scene.load(tmp_path / f"s{suffix}")
        assert back == scene and back.to_dict() == scene.to_dict()


# ---------------------------------------------------------------------------------------------------------------
# scene files of any content
# ---------------------------------------------------------------------------------------------------------------

_KEYS = st.sampled_from(["name", "description", "domain", "material", "effects", "solver", "shape", "width",
                         "height", "triangles", "path", "scale", "model", "youngs_modulus", "poisson_ratio",
                         "density", "handles", "region", "box", "near", "radius", "inertia", "time_step",
                         "gravity", "acceleration", "probes", "center", "budget", "rtol", "linear_solver",
                         "incisions", "excisions", "sutures", "fibers", "x", "", "é", "1"])
_WORDS = st.sampled_from(["rectangle", "flap", "fusiform", "file", "neo-hookean", "linear", "corotated",
                          "left", "right", "top", "m.msh", "reuse", "nan", "inf", "-inf", "NaN", "1e999", "",
                          "x" * 300])
_NUMBERS = st.one_of(st.integers(-3, 3), st.sampled_from([0, 1, 2, 800, 10**6, 10**18, -(10**18), 2**63, 10**40]),
                     st.floats(allow_nan=True, allow_infinity=True),
                     st.sampled_from([0.0, -0.0, 1e-300, 5e-324, 1e308, 0.3, 0.5, 1000.0, math.nan, math.inf]))
_LEAVES = st.one_of(_NUMBERS, _WORDS, st.booleans())
_VALUES = st.recursive(_LEAVES, lambda inner: st.one_of(st.lists(inner, max_size=4),
                                                        st.dictionaries(_KEYS, inner, max_size=4)),
                       max_leaves=12)
# a scene near a valid one: every section present or missing, each field right, wrong or absent
_VALID = demo_scene(n_triangles=60).to_dict()


@st.composite
def _scene_data(draw):
    data = {}
    for section, content in _VALID.items():
        choice = draw(st.integers(0, 3))
        if choice == 0:
            continue  # a missing section
        if choice == 1 or not isinstance(content, dict):
            data[section] = content if draw(st.booleans()) else draw(_VALUES)
            continue
        table = {k: (v if draw(st.integers(0, 2)) else draw(_VALUES)) for k, v in content.items()
                 if draw(st.integers(0, 4))}
        table.update(draw(st.dictionaries(_KEYS, _VALUES, max_size=2)))
        data[section] = table
    data.update(draw(st.dictionaries(_KEYS, _VALUES, max_size=2)))
    return data


def _toml_value(v):
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, float):
        return "nan" if math.isnan(v) else ("inf" if v > 0 else "-inf") if math.isinf(v) else repr(v)
    if isinstance(v, int):
        return str(v)
    if isinstance(v, str):
        return json.dumps(v)
    if isinstance(v, list):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    return "{" + ", ".join(f"{json.dumps(k)} = {_toml_value(x)}" for k, x in v.items()) + "}"


def _as_toml(data):
    """The data as TOML text: top-level tables as [sections], the rest inline (a generated text, right or not)."""
    lines = [f"{json.dumps(k)} = {_toml_value(v)}" for k, v in data.items() if not isinstance(v, dict)]
    for k, v in data.items():
        if isinstance(v, dict):
            lines.append(f"[{json.dumps(k)}]")
            lines += [f"{json.dumps(kk)} = {_toml_value(vv)}" for kk, vv in v.items()]
    return "\n".join(lines) + "\n"


_MANGLE = st.sampled_from([None, "cut", "bracket", "duplicate", "nan-word"])


def _mangled(text, how):
    if how == "cut":
        return text[: len(text) // 2]
    if how == "bracket":
        return "[[domain]\n" + text
    if how == "duplicate":
        return text + text
    if how == "nan-word":
        return text.replace("1000.0", "NaN").replace("0.3", "Infinity")
    return text


def _load(path):
    """``Scene.load(path)``: a Scene, or the ParameterError it raised (any other exception fails the test)."""
    try:
        return Scene.load(path)
    except ParameterError as err:
        assert err.field and str(err), err
        assert str(err).split(":")[0].split(" ")[0].strip() or err.field
        return err


@SETTINGS
@given(data=_scene_data(), kind=st.sampled_from([".toml", ".json"]), how=_MANGLE)
def test_any_scene_file_gives_a_scene_or_a_parameter_error_naming_a_field(tmp_path, data, kind, how):
    text = _as_toml(data) if kind == ".toml" else json.dumps(data, allow_nan=True)
    path = tmp_path / f"scene{kind}"
    path.write_text(_mangled(text, how), encoding="utf-8")
    answer = _load(path)
    if isinstance(answer, Scene):
        assert Scene.from_dict(answer.to_dict()) == answer
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        status = cli.main(["scene", str(path), "--check"])
    assert status == (0 if isinstance(answer, Scene) else 2), err.getvalue()
    assert "Traceback" not in err.getvalue() and "unexpected" not in err.getvalue(), err.getvalue()


# ---------------------------------------------------------------------------------------------------------------
# mesh files of any content
# ---------------------------------------------------------------------------------------------------------------

_SQUARE = rectangle(1.0, 1.0, 2, 2)  # 9 nodes, 8 counter-clockwise triangles
_CHANGES = ["unused node", "repeated node", "inverted", "degenerate", "NaN", "infinite", "huge", "3D", "planar 3D",
            "quad", "tetra", "line", "vertex", "out of range", "shuffled", "no triangles"]


def _changed(change, points, triangles, cells, rng):
    """A small mesh file's content after one change (most of them something ``read_mesh`` must refuse)."""
    i = int(rng.integers(triangles.shape[0]))
    if change == "unused node":
        points = np.vstack([points, [[3.0, 3.0]]])
    elif change == "repeated node":
        points = np.vstack([points, points[triangles[i, 0]]])
        triangles[i, 0] = points.shape[0] - 1
    elif change == "inverted":
        triangles[i] = triangles[i, ::-1]
    elif change == "degenerate":
        triangles[i, 2] = triangles[i, 1]
    elif change in ("NaN", "infinite", "huge"):
        points[int(rng.integers(points.shape[0])), 0] = {"NaN": np.nan, "infinite": np.inf, "huge": 1e300}[change]
    elif change in ("3D", "planar 3D"):
        z = rng.uniform(-1.0, 1.0, (points.shape[0], 1)) if change == "3D" else np.zeros((points.shape[0], 1))
        points = np.hstack([points[:, :2], z])
    elif change in ("quad", "tetra", "line", "vertex"):
        size = {"quad": 4, "tetra": 4, "line": 2, "vertex": 1}[change]
        cells.append((change, np.arange(size, dtype=np.int64)[None, :]))
    elif change == "out of range":
        triangles[i, 1] = points.shape[0] + 5
    elif change == "shuffled":
        triangles = triangles[rng.permutation(triangles.shape[0])]
    elif change == "no triangles":
        triangles = triangles[:0]
    return points, triangles, cells


@st.composite
def _changed_square(draw):
    """The unit square's mesh with a few changes, applied in order."""
    rng = np.random.default_rng(draw(st.integers(0, 2**16)))
    points, triangles, cells = _SQUARE.p.T.copy(), _SQUARE.t.T.copy(), []
    last = ("3D", "planar 3D", "no triangles")  # changes of the whole table, after those of single entries
    for change in sorted(draw(st.lists(st.sampled_from(_CHANGES), max_size=3, unique=True)), key=lambda c: c in last):
        points, triangles, cells = _changed(change, points, triangles, cells, rng)
    return meshio.Mesh(points, ([("triangle", triangles)] if triangles.size else []) + cells)


@st.composite
def _random_mesh(draw):
    """A few random points and cells: mostly nonsense."""
    n = draw(st.integers(1, 8))
    coordinate = st.one_of(st.floats(-2.0, 2.0), st.sampled_from([0.0, 1.0, math.nan, math.inf, 1e300, -1e-300]))
    dim = draw(st.sampled_from([2, 3]))
    points = np.array(draw(st.lists(st.lists(coordinate, min_size=dim, max_size=dim), min_size=n, max_size=n)))
    index = st.integers(-1, n)  # -1 and n: out of range
    cells = []
    for kind, size in draw(st.lists(st.sampled_from([("triangle", 3), ("line", 2), ("vertex", 1), ("quad", 4)]),
                                    min_size=1, max_size=3)):
        rows = draw(st.lists(st.lists(index, min_size=size, max_size=size), min_size=1, max_size=4))
        cells.append((kind, np.array(rows, dtype=np.int64)))
    return meshio.Mesh(points, cells)


_MESHES = st.one_of(_changed_square(), _random_mesh())


_FORMATS = st.sampled_from([(".vtk", None), (".vtu", None), (".msh", "gmsh22"), (".msh", "gmsh"), (".obj", None)])


@SETTINGS
@given(mesh=_MESHES, form=_FORMATS, scale=st.sampled_from([1.0, 1e-3, 2.5]))
def test_any_mesh_file_gives_a_valid_mesh_or_a_parameter_error_naming_domain_path(tmp_path, mesh, form, scale):
    suffix, file_format = form
    path = tmp_path / f"m{suffix}"
    try:
        with warnings.catch_warnings(), contextlib.redirect_stdout(io.StringIO()), \
                contextlib.redirect_stderr(io.StringIO()):
            warnings.simplefilter("ignore")
            meshio.write(str(path), mesh, file_format=file_format)
    except Exception:  # a mesh this format cannot hold: meshio's business, not ours
        return
    notes = []
    try:
        back = read_mesh(path, scale, notes=notes)
    except ParameterError as err:
        assert err.field == "domain.path" and "\n" not in str(err), str(err)
        return
    check_mesh(back.p, back.t)  # no unused nodes, not folded, finite, within the limits
    assert np.all(np.isfinite(back.p)) and back.nelements >= 1
    # a dropped node is said (and a tetrahedron read the other way round, when a tetra cell made it 3D)
    assert sum("dropped" in note for note in notes) == (back.nvertices < len(mesh.points)) and len(notes) <= 2
