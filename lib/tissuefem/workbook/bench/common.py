"""What every benchmark shares: the machine record, argument checks, and writing and reading results
(benchmarks measure, never draw: figures read their results through :func:`load_results`)."""

from __future__ import annotations

import csv
import json
import math
import os
import platform
import sys
from pathlib import Path

import numpy as np
import scipy
import skfem

from ...engine.parameters import check_count, count_list

__all__ = ["machine_info", "load_average", "check_sizes", "write_json", "write_csv", "write_record", "load_results",
           "recorded", "median_rows"]

#: the recorded runs shipped with the package (chapters and docs/benchmarks.md print from them)
DATA = Path(__file__).parents[1] / "data"


def load_average() -> list[float]:
    """The load average over 1, 5 and 15 minutes (a quiet 2-core machine: well under 1)."""
    return [round(x, 2) for x in os.getloadavg()]


def machine_info() -> dict:
    """The benchmark record's machine: platform, versions, CPU count and :func:`load_average` at the start."""
    return {"platform": platform.platform(), "machine": platform.machine(),
            "processor": platform.processor(), "python": sys.version.split()[0],
            "numpy": np.__version__, "scipy": scipy.__version__, "scikit-fem": skfem.__version__,
            "cpu_count": os.cpu_count(), "load_average": load_average()}


def check_sizes(sizes) -> list[int]:
    """The mesh sizes (a non-empty list or tuple) as positive ints."""
    return [check_count("sizes", s) for s in count_list("sizes", sizes, "mesh sizes", math.inf)]


def _json_ready(x):
    if isinstance(x, (np.ndarray, np.generic)):
        x = x.tolist()
    if isinstance(x, dict):
        return {str(k): _json_ready(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_json_ready(v) for v in x]
    return None if isinstance(x, float) and not math.isfinite(x) else x


def write_json(path, record) -> Path:
    """Write a benchmark record as JSON (NaN and infinities as null); returns the path."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(_json_ready(record), indent=2) + "\n", encoding="utf-8")
    return path


def write_csv(path, rows, extra=None) -> Path:
    """Write the rows' scalar columns as CSV (per-frame lists stay in the JSON), with ``extra`` columns
    (the machine and library versions) repeated on every row; returns the path."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    extra = extra or {}
    keys = list(dict.fromkeys(k for row in rows for k, v in row.items()
                              if not isinstance(v, (list, dict, np.ndarray))))
    keys += [k for k in extra if k not in keys]
    with open(path, "w", encoding="utf-8", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=keys, extrasaction="ignore")
        writer.writeheader()
        writer.writerows({**row, **extra} for row in rows)
    return path


def write_record(out, name: str, record: dict, rows, say) -> None:
    """Write ``<name>.json`` (the record) and ``<name>.csv`` (the rows) into the folder ``out`` and ``say`` where;
    no folder (``None``): nothing."""
    if out is not None:
        written = [write_json(Path(out) / f"{name}.json", record), write_csv(Path(out) / f"{name}.csv", rows)]
        say("wrote " + ", ".join(str(w) for w in written))


def load_results(path) -> dict:
    """Read a benchmark record written by :func:`write_json` (the one reader the figures use)."""
    path = Path(path)
    if not path.is_file():
        raise ValueError(f"no benchmark results at {path.name!r}")
    try:
        return json.loads(path.read_text(encoding="utf-8"))
    except json.JSONDecodeError as err:
        raise ValueError(f"{path.name}: not a benchmark record ({err})") from None


def recorded(name: str) -> dict:
    """A recorded run shipped with the package (``data/<name>.json``)."""
    return load_results(DATA / f"{name}.json")


def median_rows(rounds, key: str) -> list[dict]:
    """The rows of several rounds of one benchmark joined on ``key`` (in the first round's order): each number
    the median over the rounds, with ``<column>_range`` its ``(min, max)`` where they differ; other values from the
    first round."""
    out = []
    for row in rounds[0]:
        same = [r for rows in rounds for r in rows if r[key] == row[key]]
        joined = dict(row)
        for column, value in row.items():
            values = [r.get(column) for r in same]
            numbers = all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in values)
            if column != key and numbers and len(set(values)) > 1:
                joined[column] = float(np.median(values))
                joined[f"{column}_range"] = (float(min(values)), float(max(values)))
        out.append(joined)
    return out
