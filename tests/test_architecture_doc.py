"""docs/architecture.md stays true: every ```python block in it runs, in order, in one namespace."""

import re
from pathlib import Path

import pytest

from tissuefem.engine import effects

DOC = Path(__file__).resolve().parents[1] / "docs" / "architecture.md"


@pytest.fixture
def registry():
    """The registry as it was: a block may register an example effect."""
    saved = dict(effects.EFFECTS)
    yield
    effects.EFFECTS.clear()
    effects.EFFECTS.update(saved)


def test_every_example_of_the_architecture_runs(registry):
    blocks = re.findall(r"```python\n(.*?)```", DOC.read_text(encoding="utf-8"), re.S)
    assert len(blocks) >= 3
    namespace = {}
    for i, block in enumerate(blocks):
        exec(compile(block, f"{DOC.name}, python block {i + 1}", "exec"), namespace)
