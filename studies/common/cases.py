"""Case files for the studies: the base cases in ``cases/`` plus overrides, merged as JSON.

``derive(base, overrides)`` merges recursively: a dict in ``overrides`` merges into the dict at
the same key, anything else (numbers, strings, lists) replaces it. Study cases are therefore
written as "the base case, with these changes", and the merged case is what is hashed into the
cache key and written beside the run.
"""

from __future__ import annotations

import copy
import json
from pathlib import Path

from studies.common.paths import PrerequisiteMissing, repo_root


def base_case(name: str) -> tuple[dict, Path]:
    """Read ``cases/<name>.json``; PrerequisiteMissing if it is not there yet."""
    path = repo_root() / "cases" / f"{name}.json"
    if not path.is_file():
        raise PrerequisiteMissing(f"cases/{name}.json")
    return json.loads(path.read_text()), path


# pfm-mpm's shape function when a case leaves solver.shape_function out (mpm/step/case.cpp).
DEFAULT_SHAPE_FUNCTION = "quadratic_bspline"


def is_bspline(shape_function: str | None) -> bool:
    """Whether the shape function (None: pfm-mpm's default) is a B-spline. Their edge functions
    hold supports on the grid's edges, so a body held there needs no margin of cells around it
    (linear and uGIMP take two, with walls on node sets)."""
    return (shape_function or DEFAULT_SHAPE_FUNCTION).endswith("bspline")


def derive(base: dict, overrides: dict) -> dict:
    merged = copy.deepcopy(base)
    for key, value in overrides.items():
        if isinstance(value, dict) and isinstance(merged.get(key), dict):
            merged[key] = derive(merged[key], value)
        else:
            merged[key] = copy.deepcopy(value)
    return merged


def cell_size(case: dict) -> float:
    return float(case["grid"]["cell_size"])


def body_polygon(case: dict, index: int = 0) -> list:
    """The body's outline as a counter-clockwise vertex list (rectangle or polygon)."""
    body = case["bodies"][index]
    if "rectangle" in body:
        (x0, y0), (x1, y1) = body["rectangle"]
        return [[x0, y0], [x1, y0], [x1, y1], [x0, y1]]
    return [list(p) for p in body["polygon"]]


def inclined_edge(polygon: list) -> tuple[tuple, tuple]:
    """(crest, toe) of a slope outline: the ends of its longest edge that is neither
    horizontal nor vertical, the higher end being the crest."""
    best, best_length = None, 0.0
    n = len(polygon)
    for i in range(n):
        (xa, ya), (xb, yb) = polygon[i], polygon[(i + 1) % n]
        if abs(xa - xb) > 1e-9 and abs(ya - yb) > 1e-9:
            length = ((xa - xb) ** 2 + (ya - yb) ** 2) ** 0.5
            if length > best_length:
                best, best_length = ((xa, ya), (xb, yb)), length
    if best is None:
        raise ValueError("the body outline has no inclined edge (not a slope)")
    a, b = best
    return (a, b) if a[1] > b[1] else (b, a)
