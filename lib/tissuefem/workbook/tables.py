"""Tables of results, for the studies and the benchmarks alike: ``columns`` is ``[(key, title, format), ...]``
and a row is a dict; a missing or non-finite value prints as ``-``."""

from __future__ import annotations

import math

__all__ = ["markdown_table"]


def markdown_table(rows, columns, text_columns: int = 0) -> str:
    """Rows as a Markdown table: the first ``text_columns`` columns left-aligned, the rest (numbers) right-aligned."""
    def cell(value, fmt: str) -> str:
        missing = value is None or (isinstance(value, float) and not math.isfinite(value))
        return "-" if missing else fmt.format(value)

    lines = ["| " + " | ".join(title for _, title, _ in columns) + " |",
             "|" + "---|" * text_columns + "---:|" * (len(columns) - text_columns)]
    for row in rows:
        lines.append("| " + " | ".join(cell(row.get(key), fmt) for key, _, fmt in columns) + " |")
    return "\n".join(lines)
