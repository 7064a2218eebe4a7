"""The package's shape: three layers whose imports point down only, no import cycle, no hidden imports.

workbook -> surgery -> engine -> scikit-fem. The graph is read from the source
(module-level and function-level ``import`` statements), so a new module that
breaks the layering fails here, not in a reviewer's head.
"""

import ast
import os
import subprocess
import sys
from pathlib import Path

import pytest

import tissuefem

PACKAGE = Path(tissuefem.__file__).parent
LAYERS = {"engine": 0, "surgery": 1, "workbook": 2}
#: third-party modules that are optional (extras) and so may be imported where they are used
OPTIONAL = {"pypardiso", "sksparse", "pyamg", "ipywidgets", "nbclient", "nbformat", "matplotlib.pyplot", "selenium"}
#: heavy third-party modules that one path needs, imported there so that ``import tissuefem`` stays light
#: (mesh files: meshio; scene text: tomllib; contact's broad phase: scipy.spatial; the book's pages: nbconvert, jinja2)
DEFERRED = {"meshio", "skfem.io.meshio", "tomllib", "scipy.spatial", "nbconvert", "jinja2"}


def _modules():
    out = {}
    for path in PACKAGE.rglob("*.py"):
        rel = path.relative_to(PACKAGE.parent).with_suffix("")
        name = ".".join(rel.parts)
        if name.endswith(".__init__"):
            name = name[: -len(".__init__")]
        out[name] = path
    return out


MODULES = _modules()


def _imports(name, path):
    """``[(target module, inside a function)]`` for the package-internal imports of a module."""
    tree = ast.parse(path.read_text())
    is_package = path.name == "__init__.py"
    parents = {child: node for node in ast.walk(tree) for child in ast.iter_child_nodes(node)}
    found = []
    for node in ast.walk(tree):
        targets = []
        if isinstance(node, ast.ImportFrom):
            if node.level:
                base = name.split(".") if is_package else name.split(".")[:-1]
                base = base[: len(base) - (node.level - 1)]
                module = ".".join(base + ([node.module] if node.module else []))
            else:
                module = node.module or ""
            for alias in node.names:
                full = f"{module}.{alias.name}"
                targets.append(full if full in MODULES else module)
        elif isinstance(node, ast.Import):
            targets = [a.name for a in node.names]
        q, in_function = node, False
        while q in parents:
            q = parents[q]
            in_function |= isinstance(q, (ast.FunctionDef, ast.AsyncFunctionDef))
        found += [(t, in_function, node) for t in targets if t in MODULES and t != name]
        if in_function and isinstance(node, (ast.Import, ast.ImportFrom)) and not any(t in MODULES for t in targets):
            found.append((None, True, node))
    return found


def _layer(module):
    parts = module.split(".")
    return LAYERS.get(parts[1]) if len(parts) > 1 else None


def test_the_three_layers_exist_as_folders():
    for layer in LAYERS:
        assert (PACKAGE / layer / "__init__.py").is_file()
    # every module lives in a layer (the package's face and its entry point aside)
    loose = [m for m in MODULES if _layer(m) is None and m not in ("tissuefem", "tissuefem.__main__")]
    assert loose == []


@pytest.mark.parametrize("module", sorted(MODULES))
def test_imports_point_down_only(module):
    mine = _layer(module)
    if mine is None:
        return
    for target, _, node in _imports(module, MODULES[module]):
        if target is None:
            continue
        theirs = _layer(target)
        assert theirs is not None and theirs <= mine, \
            f"{module} (line {node.lineno}) imports {target}: a lower layer may not import a higher one"


@pytest.mark.parametrize("module", sorted(MODULES))
def test_imports_sit_at_module_level_except_optional_dependencies(module):
    for target, in_function, node in _imports(module, MODULES[module]):
        if not in_function:
            continue
        names = [a.name for a in node.names]
        what = node.module if isinstance(node, ast.ImportFrom) else names[0]
        assert target is None and (what in OPTIONAL | DEFERRED or (what or "").split(".")[0] in OPTIONAL), \
            f"{module} (line {node.lineno}) imports {target or what} inside a function"


def test_there_is_no_import_cycle():
    graph = {m: {t for t, _, _ in _imports(m, p) if t} for m, p in MODULES.items()}
    # a package's face imports its contents; the contents never import the face back, so drop nothing
    state = {}

    def visit(m, stack):
        state[m] = "open"
        for t in graph[m]:
            if state.get(t) == "open":
                cycle = stack[stack.index(t):] + [t]
                raise AssertionError("import cycle: " + " -> ".join(cycle))
            if t not in state:
                visit(t, stack + [t])
        state[m] = "done"

    for m in graph:
        if m not in state:
            visit(m, [m])


@pytest.mark.parametrize("module", sorted(MODULES))
def test_no_private_name_is_imported_from_another_module(module):
    """What modules share is public: ``from .x import _helper`` would tie one module to another's insides."""
    tree = ast.parse(MODULES[module].read_text())
    private = [f"{node.module or '.'}.{alias.name}" for node in ast.walk(tree)
               if isinstance(node, ast.ImportFrom) and (node.level > 0 or (node.module or "").startswith("tissuefem"))
               for alias in node.names if alias.name.startswith("_")]
    assert not private, f"{module} imports private names: {private}"


# ------------------------------------------------------------------ the package's face
def _fresh_python(code):
    """``code``'s printed output in a new interpreter that imports this package (not an installed copy)."""
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(PACKAGE.parent), os.environ.get("PYTHONPATH", "")]))
    return subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True).stdout


def test_import_tissuefem_loads_none_of_its_modules_until_a_name_is_used():
    """The face is lazy (PEP 562): ``import tissuefem`` costs no numpy, scipy or scikit-fem; the first use of a name
    imports that name's module (and what it needs), nothing more."""
    code = ("import sys, tissuefem\n"
            "heavy = ('tissuefem.', 'skfem', 'scipy.sparse', 'scipy.linalg', 'scipy.optimize', 'matplotlib')\n"
            "print(sorted(m for m in sys.modules if m.startswith(heavy)))\n"
            "tissuefem.Bar1D\n"
            "print('tissuefem.engine.bar1d' in sys.modules, 'tissuefem.surgery' in sys.modules)")
    assert _fresh_python(code).split("\n")[:2] == ["[]", "True False"]


def test_every_name_of_the_face_resolves_and_is_listed():
    names = set(tissuefem.__all__)
    assert len(names) == len(tissuefem.__all__), "a name is listed twice"
    for name in tissuefem.__all__:
        value = getattr(tissuefem, name)
        assert value is not None, name
        if name != "__version__" and hasattr(value, "__module__") and not isinstance(value, type(tissuefem)):
            assert value.__module__.startswith("tissuefem."), (name, value.__module__)
    assert names <= set(dir(tissuefem))
    namespace = {}
    exec("from tissuefem import *", namespace)
    assert names <= set(namespace)
    from tissuefem import Model, Simulation, solve  # the form the chapters use
    assert (Model, Simulation, solve) == (tissuefem.Model, tissuefem.Simulation, tissuefem.solve)


def test_an_unknown_name_is_an_attribute_error():
    with pytest.raises(AttributeError, match="SurgeryView"):
        tissuefem.SurgeryView
    with pytest.raises(ImportError):
        exec("from tissuefem import NoSuchThing", {})
    assert tissuefem.engine.__name__ == "tissuefem.engine"  # the layers stay reachable as attributes
