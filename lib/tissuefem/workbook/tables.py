"""Tables of results, for the studies and the benchmarks alike: ``columns`` is ``[(key, title, format), ...]``
and a row is a dict; a missing or non-finite value prints as ``-``."""

from __future__ import annotations

import math

__all__ = ["cell_text", "markdown_table"]


def cell_text(value, fmt: str) -> str:
    """``fmt.format(value)``, or ``-`` for a missing or non-finite value."""
    return "-" if value is None or (isinstance(value, float) and not math.isfinite(value)) else fmt.format(value)


def markdown_table(rows, columns, text_columns: int = 0) -> str:
    """Rows as a Markdown table: the first ``text_columns`` columns left-aligned, the rest (numbers) right-aligned."""
    lines = ["| " + " | ".join(title for _, title, _ in columns) + " |",
             "|" + "---|" * text_columns + "---:|" * (len(columns) - text_columns)]
    for row in rows:
        lines.append("| " + " | ".join(cell_text(row.get(key), fmt) for key, _, fmt in columns) + " |")
    return "\n".join(lines)

