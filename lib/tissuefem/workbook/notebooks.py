"""Execute the chapter notebooks headless (the ``build`` command and the test suite).

Executed copies go to a build folder, so the committed chapters stay free of outputs.
"""

from __future__ import annotations

import ast
import os
import re
import tempfile
import time
from pathlib import Path

from traitlets.config import Config

#: A chapter's file name: ``chNN_name.ipynb``, or ``chNNa_name.ipynb``, ``chNNb_...`` for the parts of a
#: chapter split into sittings.
CHAPTER_NAME = re.compile(r"ch(\d\d)([a-z]?)_\w+\.ipynb")


def chapter_paths(chapters_dir) -> list[Path]:
    """All chapter notebooks ``chNN_*.ipynb`` and ``chNNa_*.ipynb`` (parts of a chapter) in order."""
    return sorted(p for p in Path(chapters_dir).glob("ch*.ipynb") if CHAPTER_NAME.fullmatch(p.name))


def chapter_label(path) -> str:
    """``"6"`` for ``ch06_inversion.ipynb``, ``"6a"`` for ``ch06a_...``: the chapter's number as the book shows it."""
    m = CHAPTER_NAME.fullmatch(Path(path).name)
    if m is None:
        raise ValueError(f"{Path(path).name} is not a chapter file name (chNN_name.ipynb or chNNa_name.ipynb)")
    return f"{int(m.group(1))}{m.group(2)}"


def execute_notebook(src, dst=None, timeout: int = 900):
    """Run every cell of ``src`` in a fresh Python kernel (working directory: the notebook's folder); return the
    executed notebook and write it to ``dst`` when given. A failing cell raises
    ``nbclient.exceptions.CellExecutionError`` naming the cell. The kernel talks over local sockets (IPC)
    where the system has them: over TCP it would warn, once per chapter, that the traffic is unencrypted."""
    import nbformat
    from nbclient import NotebookClient

    src = Path(src)
    nb = nbformat.read(src, as_version=4)
    with tempfile.TemporaryDirectory(prefix="tissuefem-kernel-") as sockets:
        # the socket files' absolute prefix: the kernel runs in the chapter's folder, the client here
        config = (Config({"KernelManager": {"transport": "ipc", "ip": os.path.join(sockets, "kernel")}})
                  if os.name == "posix" else Config())
        NotebookClient(nb, timeout=timeout, kernel_name="python3", config=config,
                       resources={"metadata": {"path": str(src.parent)}}).execute()
    if dst is not None:
        dst = Path(dst)
        dst.parent.mkdir(parents=True, exist_ok=True)
        nbformat.write(nb, dst)
    return nb


def build_chapters(chapters_dir, outdir, names=None) -> list[Path]:
    """Execute the chapters (all, or those whose file name contains one of ``names``)."""
    paths = chapter_paths(chapters_dir)
    if names:
        paths = [p for p in paths if any(n in p.name for n in names)]
        if not paths:
            raise ValueError(f"no chapter matches {names}")
    done, start = [], time.perf_counter()
    for i, path in enumerate(paths, 1):
        t0 = time.perf_counter()
        print(f"[chapter {i}/{len(paths)}] executing {path.name} ...")
        dst = Path(outdir) / path.name
        execute_notebook(path, dst)
        done.append(dst)
        print(f"[chapter {i}/{len(paths)}] {path.name} -> {dst}  ({time.perf_counter() - t0:.1f} s, "
              f"total {time.perf_counter() - start:.1f} s)")
    return done


def _code(cell) -> str:
    text = "".join(cell["source"]) if isinstance(cell["source"], list) else cell["source"]
    # IPython magics and shell escapes are not Python
    return "\n".join("" if line.lstrip().startswith(("%", "!")) else line for line in text.splitlines())


def figure_calls(cell) -> list[tuple[str, bool]]:
    """``(name, shown)`` for each ``fig_*(...)`` call of a code cell: shown when the call is the cell's last
    expression (Jupyter displays its value) or is passed to ``display(...)``. A figure drawn anywhere else is
    returned and dropped: the executed chapter and the book never show it."""
    tree = ast.parse(_code(cell))
    last = tree.body[-1] if tree.body else None
    calls = [node for node in ast.walk(tree) if isinstance(node, ast.Call) and isinstance(node.func, ast.Name)]
    displayed = {id(arg) for node in calls if node.func.id == "display" for arg in node.args}
    return [(node.func.id, (isinstance(last, ast.Expr) and last.value is node) or id(node) in displayed)
            for node in calls if node.func.id.startswith("fig_")]


def missing_figures(nb) -> list[str]:
    """The figures the code cells of an executed notebook draw but do not show as an image, one line per cell."""
    missing = []
    for i, cell in enumerate(nb["cells"]):
        calls = figure_calls(cell) if cell["cell_type"] == "code" else []
        if not calls:
            continue
        images = sum(1 for out in cell.get("outputs", []) if any(k.startswith("image/") for k in out.get("data", {})))
        if images < len(calls):
            missing.append(f"cell {i}: {', '.join(name for name, _ in calls)} drew {len(calls)} figure(s) "
                           f"but shows {images} image(s)")
    return missing
