"""Reading of the project's case JSON files (schema: /work/main/README.md, "Case-file reference").

The reader mirrors the C++ one: unknown keys, missing required keys and bad values raise
CaseError naming the file and the JSON pointer. Only what the finite element model needs is
interpreted; MPM-only keys (points_per_cell, placement, solver, output) are validated for type
and otherwise ignored.
"""
from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from typing import Optional


class CaseError(ValueError):
    """Bad case file: '<file>: <pointer>: <message>'."""


def _fail(file: str, pointer: str, message: str):
    raise CaseError(f"{file}: {pointer or '/'}: {message}")


def _expect_object(value, file, pointer, allowed):
    if not isinstance(value, dict):
        _fail(file, pointer, "must be an object")
    for key in value:
        if key not in allowed:
            _fail(file, f"{pointer}/{key}", "unknown key")


_POSITIVE = (lambda v: v > 0, "must be > 0")
_NON_NEGATIVE = (lambda v: v >= 0, "must be >= 0")


def _number(obj, key, file, pointer, default=None, required=False, check=None, what="",
            rule=None):
    if rule is not None:
        check, what = rule
    if key not in obj:
        if required:
            _fail(file, f"{pointer}/{key}", "missing key")
        return default
    value = obj[key]
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        _fail(file, f"{pointer}/{key}", "must be a number")
    if check is not None and not check(value):
        _fail(file, f"{pointer}/{key}", what)
    return float(value)


def _point(value, file, pointer):
    if (not isinstance(value, list) or len(value) != 2
            or not all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in value)):
        _fail(file, pointer, "must be [x, y]")
    return (float(value[0]), float(value[1]))


@dataclass
class Cohesion:
    """c(eps_p): piecewise linear through (x[k], y[k]), constant outside."""
    x: list
    y: list

    def value(self, eps_p):
        import numpy as np
        return np.interp(eps_p, self.x, self.y)

    def slope(self, eps_p):
        import numpy as np
        xs = np.asarray(self.x)
        ys = np.asarray(self.y)
        if len(xs) < 2:
            return np.zeros_like(eps_p)
        k = np.clip(np.searchsorted(xs, eps_p, side="right"), 1, len(xs) - 1)
        s = (ys[k] - ys[k - 1]) / (xs[k] - xs[k - 1])
        return np.where((eps_p < xs[0]) | (eps_p >= xs[-1]), 0.0, s)


@dataclass
class Material:
    name: str
    model: str  # linear_elastic | tresca | mohr_coulomb
    youngs_modulus: float
    poisson_ratio: float
    unit_weight: float
    cohesion: Optional[Cohesion] = None
    friction_angle: float = 0.0
    dilation_angle: float = 0.0
    tension_cutoff: Optional[float] = None

    @property
    def shear_modulus(self):
        return self.youngs_modulus / (2.0 * (1.0 + self.poisson_ratio))

    @property
    def lame_lambda(self):
        e, nu = self.youngs_modulus, self.poisson_ratio
        return e * nu / ((1.0 + nu) * (1.0 - 2.0 * nu))

    @property
    def constrained_modulus(self):
        return self.lame_lambda + 2.0 * self.shear_modulus


@dataclass
class Body:
    name: str
    material: str
    polygon: list  # [(x, y), ...] counter-clockwise after reading


@dataclass
class Load:
    pressure: float
    x_range: tuple
    time_function: dict


@dataclass
class Case:
    file: str
    title: str
    origin: tuple
    cell_size: float
    n_cells: tuple
    materials: dict
    bodies: list
    g: float
    gravity_ramp_time: float
    initial_stress: str
    k0: Optional[float]
    node_sets: dict
    boundary_conditions: list  # [(where, fix)]
    loads: list
    damping: float
    end_time: float
    cfl: float
    dt: Optional[float]
    raw: dict = field(repr=False, default_factory=dict)

    @property
    def grid_box(self):
        x0, y0 = self.origin
        width, height = self.n_cells[0] * self.cell_size, self.n_cells[1] * self.cell_size
        return (x0, y0, x0 + width, y0 + height)


def _read_cohesion(value, file, pointer):
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        if value < 0:
            _fail(file, pointer, "must be >= 0")
        return Cohesion([0.0], [float(value)])
    if isinstance(value, dict) and "table" in value:
        _expect_object(value, file, pointer, {"table"})
        table = value["table"]
        if not isinstance(table, list) or len(table) < 1:
            _fail(file, pointer + "/table", "must be a non-empty list of [eps_p, c]")
        pts = [_point(p, file, f"{pointer}/table/{k}") for k, p in enumerate(table)]
        xs = [p[0] for p in pts]
        if any(b <= a for a, b in zip(xs, xs[1:])):
            _fail(file, pointer + "/table", "eps_p must be strictly increasing")
        return Cohesion(xs, [p[1] for p in pts])
    if isinstance(value, dict):
        keys = ("initial", "peak", "residual", "peak_plastic_strain", "residual_plastic_strain")
        _expect_object(value, file, pointer, set(keys))
        v = {k: _number(value, k, file, pointer, required=True) for k in keys}
        if not 0 <= v["peak_plastic_strain"] < v["residual_plastic_strain"]:
            _fail(file, pointer, "need 0 <= peak_plastic_strain < residual_plastic_strain")
        xs = [0.0, v["peak_plastic_strain"], v["residual_plastic_strain"]]
        ys = [v["initial"], v["peak"], v["residual"]]
        if xs[1] == 0.0:
            xs, ys = xs[1:], ys[1:]
        return Cohesion(xs, ys)
    _fail(file, pointer, "must be a number or a cohesion object")


def _ccw(polygon):
    area = 0.0
    for (xa, ya), (xb, yb) in zip(polygon, polygon[1:] + polygon[:1]):
        area += xa * yb - xb * ya
    if area == 0.0:
        raise ValueError("degenerate polygon")
    return polygon if area > 0 else polygon[::-1]


def read_case(path: str) -> Case:
    """Read and validate a case file; raises CaseError."""
    file = str(path)
    try:
        with open(file) as f:
            root = json.load(f)
    except (OSError, json.JSONDecodeError) as err:
        raise CaseError(f"{file}: cannot read JSON: {err}") from err
    return case_from_dict(root, file)


def case_from_dict(root: dict, file: str = "<dict>") -> Case:
    _expect_object(root, file, "", {"title", "grid", "materials", "bodies", "gravity",
                                    "initial_stress", "node_sets", "boundary_conditions",
                                    "loads", "solver", "time", "output"})
    title = root.get("title", "")
    if "grid" not in root:
        _fail(file, "/grid", "missing key")
    grid = root["grid"]
    _expect_object(grid, file, "/grid", {"origin", "cell_size", "n_cells"})
    origin = _point(grid.get("origin", [0, 0]), file, "/grid/origin")
    cell_size = _number(grid, "cell_size", file, "/grid", required=True,
                        rule=_POSITIVE)
    if "n_cells" not in grid:
        _fail(file, "/grid/n_cells", "missing key")
    nc = grid["n_cells"]
    if not (isinstance(nc, list) and len(nc) == 2
            and all(isinstance(n, int) and not isinstance(n, bool) and n >= 1 for n in nc)):
        _fail(file, "/grid/n_cells", "must be [nx, ny], integers >= 1")

    if not isinstance(root.get("materials"), list) or not root["materials"]:
        _fail(file, "/materials", "must be a non-empty list")
    materials = {}
    for k, m in enumerate(root["materials"]):
        p = f"/materials/{k}"
        _expect_object(m, file, p, {"name", "model", "youngs_modulus", "poisson_ratio",
                                    "unit_weight", "cohesion", "friction_angle",
                                    "dilation_angle", "tension_cutoff"})
        name = m.get("name")
        if not isinstance(name, str) or name in materials:
            _fail(file, p + "/name", "must be a unique string")
        model = m.get("model")
        if model not in ("linear_elastic", "tresca", "mohr_coulomb"):
            _fail(file, p + "/model", "must be linear_elastic, tresca or mohr_coulomb")
        mat = Material(
            name, model,
            _number(m, "youngs_modulus", file, p, required=True, rule=_POSITIVE),
            _number(m, "poisson_ratio", file, p, required=True, check=lambda v: 0 <= v < 0.5,
                    what="must be in [0, 0.5)"),
            _number(m, "unit_weight", file, p, required=True, rule=_NON_NEGATIVE))
        if model != "linear_elastic":
            if "cohesion" not in m:
                _fail(file, p + "/cohesion", "missing key")
            mat.cohesion = _read_cohesion(m["cohesion"], file, p + "/cohesion")
        if model == "mohr_coulomb":
            mat.friction_angle = _number(m, "friction_angle", file, p, required=True,
                                         check=lambda v: 0 <= v < 90, what="must be in [0, 90)")
            mat.dilation_angle = _number(m, "dilation_angle", file, p, default=0.0,
                                         check=lambda v: 0 <= v <= mat.friction_angle,
                                         what="must be in [0, friction_angle]")
            c0 = mat.cohesion.y[0]
            phi = math.radians(mat.friction_angle)
            default_cut = c0 / math.tan(phi) if mat.friction_angle > 0 else 0.0
            mat.tension_cutoff = _number(m, "tension_cutoff", file, p, default=default_cut,
                                         rule=_NON_NEGATIVE)
        materials[name] = mat

    if not isinstance(root.get("bodies"), list) or not root["bodies"]:
        _fail(file, "/bodies", "must be a non-empty list")
    bodies = []
    for k, b in enumerate(root["bodies"]):
        p = f"/bodies/{k}"
        _expect_object(b, file, p, {"name", "material", "rectangle", "polygon",
                                    "points_per_cell", "placement"})
        if b.get("material") not in materials:
            _fail(file, p + "/material", "must name a material")
        if ("rectangle" in b) == ("polygon" in b):
            _fail(file, p, "needs exactly one of rectangle, polygon")
        if "rectangle" in b:
            r = b["rectangle"]
            if not isinstance(r, list) or len(r) != 2:
                _fail(file, p + "/rectangle", "must be [[x0, y0], [x1, y1]]")
            x0, y0 = _point(r[0], file, p + "/rectangle/0")
            x1, y1 = _point(r[1], file, p + "/rectangle/1")
            if not (x1 > x0 and y1 > y0):
                _fail(file, p + "/rectangle", "needs x1 > x0 and y1 > y0")
            poly = [(x0, y0), (x1, y0), (x1, y1), (x0, y1)]
        else:
            pl = b["polygon"]
            if not isinstance(pl, list) or len(pl) < 3:
                _fail(file, p + "/polygon", "must have >= 3 vertices")
            poly = [_point(v, file, f"{p}/polygon/{i}") for i, v in enumerate(pl)]
            try:
                poly = _ccw(poly)
            except ValueError:
                _fail(file, p + "/polygon", "has zero area")
        bodies.append(Body(b.get("name", f"body{k}"), b["material"], poly))

    gravity = root.get("gravity", {})
    _expect_object(gravity, file, "/gravity", {"g", "ramp_time"})
    g = _number(gravity, "g", file, "/gravity", default=9.81, rule=_NON_NEGATIVE)
    ramp = _number(gravity, "ramp_time", file, "/gravity", default=0.0, rule=_NON_NEGATIVE)

    ini = root.get("initial_stress", {})
    _expect_object(ini, file, "/initial_stress",
                   {"method", "k0", "kinetic_energy_ratio", "damping", "max_time"})
    method = ini.get("method", "zero")
    if method not in ("zero", "k0", "gravity"):
        _fail(file, "/initial_stress/method", "must be zero, k0 or gravity")
    k0 = _number(ini, "k0", file, "/initial_stress", default=None, rule=_NON_NEGATIVE)

    node_sets = {}
    for k, ns in enumerate(root.get("node_sets", [])):
        p = f"/node_sets/{k}"
        _expect_object(ns, file, p, {"name", "box"})
        box = ns.get("box")
        if not isinstance(box, list) or len(box) != 2:
            _fail(file, p + "/box", "must be [[x0, y0], [x1, y1]]")
        node_sets[ns.get("name")] = (_point(box[0], file, p + "/box/0"),
                                     _point(box[1], file, p + "/box/1"))

    bcs = []
    for k, bc in enumerate(root.get("boundary_conditions", [])):
        p = f"/boundary_conditions/{k}"
        _expect_object(bc, file, p, {"where", "fix"})
        where = bc.get("where")
        if where not in ("left", "right", "bottom", "top") and where not in node_sets:
            _fail(file, p + "/where", "must be left, right, bottom, top or a node-set name")
        if bc.get("fix") not in ("x", "y", "xy"):
            _fail(file, p + "/fix", "must be x, y or xy")
        bcs.append((where, bc["fix"]))

    loads = []
    for k, ld in enumerate(root.get("loads", [])):
        p = f"/loads/{k}"
        _expect_object(ld, file, p, {"type", "pressure", "x_range", "apply_on", "time_function"})
        if ld.get("type") != "vertical_pressure":
            _fail(file, p + "/type", "must be vertical_pressure")
        q = _number(ld, "pressure", file, p, required=True, rule=_NON_NEGATIVE)
        if "x_range" not in ld:
            _fail(file, p + "/x_range", "missing key")
        xr = _point(ld["x_range"], file, p + "/x_range")
        if not xr[0] < xr[1]:
            _fail(file, p + "/x_range", "needs x0 < x1")
        tf = ld.get("time_function", {"type": "constant"})
        _expect_object(tf, file, p + "/time_function", {"type", "ramp_time"})
        if tf.get("type") not in ("constant", "ramp"):
            _fail(file, p + "/time_function/type", "must be constant or ramp")
        loads.append(Load(q, xr, tf))

    solver = root.get("solver", {})
    _expect_object(solver, file, "/solver", {"scheme", "shape_function", "damping"})
    damping = _number(solver, "damping", file, "/solver", default=0.0,
                      check=lambda v: 0 <= v < 1, what="must be in [0, 1)")
    if "time" not in root:
        _fail(file, "/time", "missing key")
    tm = root["time"]
    _expect_object(tm, file, "/time", {"end_time", "cfl", "dt"})
    end_time = _number(tm, "end_time", file, "/time", required=True, rule=_POSITIVE)
    cfl = _number(tm, "cfl", file, "/time", default=0.5, check=lambda v: 0 < v <= 1,
                  what="must be in (0, 1]")
    dt = _number(tm, "dt", file, "/time", default=None, rule=_POSITIVE)
    _expect_object(root.get("output", {}), file, "/output", {"interval", "timeseries_interval"})

    return Case(file, title, origin, cell_size, tuple(nc), materials, bodies, g, ramp, method, k0,
                node_sets, bcs, loads, damping, end_time, cfl, dt, raw=root)
