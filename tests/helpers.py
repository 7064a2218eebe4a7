"""Helpers shared by the tests of every layer: a chapter figure registered, documented, a PNG, byte-identical across runs."""

import hashlib

from tissuefem.workbook import figures


def assert_figure_deterministic(name, tmp_path):
    assert name in figures.FIGURES and figures.FIGURES[name].__doc__
    first = figures.generate([name], tmp_path / "a", progress=None)[0]
    second = figures.generate([name], tmp_path / "b", progress=None)[0]
    data = first.read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n"
    assert hashlib.sha256(data).digest() == hashlib.sha256(second.read_bytes()).digest()
    assert b"Software" not in data[:400]
