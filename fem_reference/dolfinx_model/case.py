"""Reading of the project's case JSON files (schema: /work/main/README.md, "Case-file reference").

The reader mirrors the C++ one (mpm/solver/case.cpp, mpm/boundary/load_input.cpp,
mpm/detect/detector.cpp): unknown keys, missing required keys and bad values raise CaseError
naming the file and the JSON pointer. Only what the finite element model needs is interpreted;
keys that matter to the MPM only (points_per_cell, placement, solver.scheme/shape_function,
output, the detection block, the discrete boundary integration of detected-boundary loads) are
validated like the C++ reader does and listed in Case.ignored with the reason.
"""
from __future__ import annotations

import dataclasses
import json
import math
from dataclasses import dataclass, field
from pathlib import Path
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


def _number(
    obj,
    key,
    file,
    pointer,
    default=None,
    required=False,
    check=None,
    what="",
    rule=None,
):
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


def _choice(obj, key, file, pointer, choices, default=None, required=False):
    if key not in obj:
        if required:
            _fail(file, f"{pointer}/{key}", "missing key")
        return default
    value = obj[key]
    if value not in choices:
        _fail(file, f"{pointer}/{key}", "must be " + ", ".join(choices))
    return value


def _bool(obj, key, file, pointer, default):
    if key not in obj:
        return default
    if not isinstance(obj[key], bool):
        _fail(file, f"{pointer}/{key}", "must be true or false")
    return obj[key]


def _int(obj, key, file, pointer, default, low, high):
    if key not in obj:
        return default
    value = obj[key]
    if isinstance(value, float) and value.is_integer():
        value = int(value)
    if isinstance(value, bool) or not isinstance(value, int):
        _fail(file, f"{pointer}/{key}", "must be a whole number")
    if not low <= value <= high:
        _fail(file, f"{pointer}/{key}", f"must be in {low}..{high}")
    return value


def _point(value, file, pointer):
    if (
        not isinstance(value, list)
        or len(value) != 2
        or not all(
            isinstance(v, (int, float)) and not isinstance(v, bool) for v in value
        )
    ):
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
    # m: the band width the cohesion law is meant for (the C++ reader's softening_length): the
    # model scales the law's plastic strains by softening_length / element size
    softening_length: Optional[float] = None

    def regularised(self, element_size: float) -> "Material":
        """This material with its cohesion law's plastic strains scaled by softening_length /
        element_size (itself without a softening length)."""
        if self.softening_length is None:
            return self
        scale = self.softening_length / element_size
        return dataclasses.replace(
            self,
            cohesion=Cohesion([x * scale for x in self.cohesion.x], self.cohesion.y),
        )

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
    """A surface load. Traction on the loaded boundary (n the outward unit normal):
    vertical_pressure t = (0, -q n_y) (vertical only, the C++ codes' rule), follower_pressure
    t = -p n, traction t = (tx, ty) per current length.

    apply_on: "grid_top_nodes" or "detected_boundary" (the FE boundary is exact, so both act on
    the mesh boundary; grid_top_nodes loads are vertical pressures on the top faces, fixed
    interval). x_range None: the whole boundary. faces: "top" (upward parts with no boundary
    above), "upward" (n_y > 0) or "all". interval: "fixed" (x_range fixed in space) or
    "material" (the ends follow the material; the same as fixed in small strain)."""

    pressure: Optional[float]
    x_range: Optional[tuple]
    time_function: dict
    type: str = "vertical_pressure"
    traction: Optional[tuple] = None
    faces: str = "top"
    interval: str = "fixed"
    apply_on: str = "grid_top_nodes"

    @property
    def magnitude(self):
        """Pressure (kPa) or, for a traction, its length (kPa): the 'load' of the outputs."""
        if self.type == "traction":
            return math.hypot(*self.traction)
        return self.pressure


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
    detection: Optional[dict] = None  # the C++ detection block (validated, unused)
    # ["/json/pointer: why it is not used", ...]
    ignored: list = field(default_factory=list)

    @property
    def grid_box(self):
        x0, y0 = self.origin
        width, height = (
            self.n_cells[0] * self.cell_size,
            self.n_cells[1] * self.cell_size,
        )
        return (x0, y0, x0 + width, y0 + height)


def _mesh_outline(path: Path, group: str, file, pointer) -> list:
    """The counter-clockwise outline of the 3-node triangles and 4-node quadrangles of the
    physical group `group` (all 2D elements when empty) of the gmsh file `path`: the element
    edges that belong to one element only, chained into one loop."""
    import gmsh

    if not path.is_file():
        _fail(file, pointer, f"{path} is not a readable file")
    gmsh.initialize(readConfigFiles=False)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.open(str(path))
        if group:
            tags = [
                t
                for d, t in gmsh.model.getPhysicalGroups(2)
                if gmsh.model.getPhysicalName(d, t) == group
            ]
            if not tags:
                _fail(file, pointer, f'{path} has no 2D physical group "{group}"')
            entities = [
                e for t in tags for e in gmsh.model.getEntitiesForPhysicalGroup(2, t)
            ]
        else:
            entities = [t for _, t in gmsh.model.getEntities(2)]
        elements, position = [], {}
        for entity in entities:
            types, _, nodes = gmsh.model.mesh.getElements(2, entity)
            for kind, tags in zip(types, nodes):
                if kind not in (2, 3):
                    _fail(file, pointer, f"{path}: bodies take 3- and 4-node elements")
                corners = 3 if kind == 2 else 4
                for e in range(len(tags) // corners):
                    elements.append(
                        [int(n) for n in tags[corners * e : corners * (e + 1)]]
                    )
        for n in {n for element in elements for n in element}:
            coord = gmsh.model.mesh.getNode(n)[0]
            position[n] = (float(coord[0]), float(coord[1]))
    finally:
        gmsh.finalize()
    if not elements:
        _fail(file, pointer, f"{path} has no triangle or quadrangle")
    edges = set()
    for element in elements:
        area = sum(
            position[a][0] * position[b][1] - position[b][0] * position[a][1]
            for a, b in zip(element, element[1:] + element[:1])
        )
        if area < 0:
            element = element[:1] + element[1:][::-1]
        edges |= set(zip(element, element[1:] + element[:1]))
    following = {a: b for a, b in edges if (b, a) not in edges}
    start = min(following)
    loop, node = [], start
    while True:
        loop.append(position[node])
        node = following[node]
        if node == start or len(loop) > len(following):
            break
    if len(loop) != len(following):
        _fail(file, pointer, "the mesh's outline is not one closed loop")
    return loop


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
        keys = (
            "initial",
            "peak",
            "residual",
            "peak_plastic_strain",
            "residual_plastic_strain",
        )
        _expect_object(value, file, pointer, set(keys))
        v = {k: _number(value, k, file, pointer, required=True) for k in keys}
        if not 0 <= v["peak_plastic_strain"] < v["residual_plastic_strain"]:
            _fail(
                file, pointer, "need 0 <= peak_plastic_strain < residual_plastic_strain"
            )
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


def _read_time_function(tf, file, pointer):
    if not isinstance(tf, dict):
        _fail(file, pointer, "must be an object")
    kind = _choice(
        tf, "type", file, pointer, ("constant", "ramp", "smooth_ramp"), required=True
    )
    if kind == "constant":
        _expect_object(tf, file, pointer, {"type"})
        return {"type": "constant"}
    _expect_object(tf, file, pointer, {"type", "ramp_time"})
    ramp = _number(tf, "ramp_time", file, pointer, required=True, rule=_POSITIVE)
    return {"type": kind, "ramp_time": ramp}


def _read_x_range(ld, file, pointer):
    if "x_range" not in ld:
        _fail(file, pointer + "/x_range", "missing key")
    xr = _point(ld["x_range"], file, pointer + "/x_range")
    if not xr[0] < xr[1]:
        _fail(file, pointer + "/x_range", "needs x0 < x1")
    return xr


# Keys of a detected-boundary load that only steer the MPM's discrete boundary integration.
MPM_INTEGRATION_KEYS = (
    "curve",
    "integration",
    "gauss_points",
    "split_at_cell_edges",
    "scale_eq_6_15",
    "redistribute_lost_load",
    "min_node_mass_fraction",
)


def _read_load(ld, file, p, ignored):
    """One element of "loads" (mpm/solver/case.cpp and mpm/boundary/load_input.cpp)."""
    if not isinstance(ld, dict):
        _fail(file, p, "must be an object")
    apply_on = _choice(
        ld,
        "apply_on",
        file,
        p,
        ("grid_top_nodes", "detected_boundary"),
        default="grid_top_nodes",
    )
    tf = {"type": "constant"}
    if apply_on == "grid_top_nodes":
        _expect_object(
            ld, file, p, {"type", "pressure", "x_range", "apply_on", "time_function"}
        )
        _choice(ld, "type", file, p, ("vertical_pressure",), required=True)
        q = _number(ld, "pressure", file, p, required=True, rule=_NON_NEGATIVE)
        xr = _read_x_range(ld, file, p)
        if "time_function" in ld:
            tf = _read_time_function(ld["time_function"], file, p + "/time_function")
        return Load(q, xr, tf, apply_on=apply_on)

    _expect_object(
        ld,
        file,
        p,
        {
            "apply_on",
            "type",
            "pressure",
            "traction",
            "x_range",
            "faces",
            "interval",
            "time_function",
            *MPM_INTEGRATION_KEYS,
        },
    )
    kind = _choice(
        ld,
        "type",
        file,
        p,
        ("vertical_pressure", "follower_pressure", "traction"),
        required=True,
    )
    pressure = traction = None
    if kind == "vertical_pressure":
        pressure = _number(
            ld,
            "pressure",
            file,
            p,
            required=True,
            check=lambda v: v >= 0,
            what="must be >= 0 (kPa, acting downwards)",
        )
    elif kind == "follower_pressure":
        pressure = _number(ld, "pressure", file, p, required=True)
    else:
        if "traction" not in ld:
            _fail(file, p + "/traction", "missing key")
        traction = _point(ld["traction"], file, p + "/traction")
        if "pressure" in ld:
            _fail(
                file, p + "/pressure", 'not used by type "traction" (give "traction")'
            )
    if kind != "traction" and "traction" in ld:
        _fail(file, p + "/traction", 'only used by type "traction"')
    xr = None
    if kind == "vertical_pressure" or "x_range" in ld:
        xr = _read_x_range(ld, file, p)
    faces = _choice(
        ld,
        "faces",
        file,
        p,
        ("top", "upward", "all"),
        default="top" if kind == "vertical_pressure" else "all",
    )
    _choice(ld, "curve", file, p, ("linear", "quadratic", "cubic", "catmull_rom"))
    _choice(ld, "integration", file, p, ("exact", "thesis"))
    _int(ld, "gauss_points", file, p, 5, 1, 20)
    for key in ("split_at_cell_edges", "scale_eq_6_15", "redistribute_lost_load"):
        _bool(ld, key, file, p, False)
    _number(
        ld,
        "min_node_mass_fraction",
        file,
        p,
        0.01,
        check=lambda v: 0 <= v < 1,
        what="must be in [0, 1) (a fraction of a full cell's mass)",
    )
    for key in MPM_INTEGRATION_KEYS:
        if key in ld:
            ignored.append(
                f"{p}/{key}: MPM boundary integration only (the finite element "
                "integrates the traction exactly on the mesh boundary)"
            )
    interval = _choice(ld, "interval", file, p, ("fixed", "material"), default="fixed")
    if "time_function" in ld:
        tf = _read_time_function(ld["time_function"], file, p + "/time_function")
    return Load(
        pressure,
        xr,
        tf,
        type=kind,
        traction=traction,
        faces=faces,
        interval=interval,
        apply_on=apply_on,
    )


# Keys of the detector blocks (mpm/detect/detector.cpp, parse_detector_config); the values are
# the C++ reader's business (the dolfinx model does not detect anything).
DETECTOR_KEYS = {
    "pfm": {
        "kernel_factor",
        "contour_level",
        "refinement",
        "negative_outside",
        "deformation",
        "min_size_factor",
        "max_size_factor",
        "edge_location",
        "bisection_steps",
        "bisection_tolerance",
        "remove_vertex_holes",
        "gaussian_sigma",
        "gaussian_size",
        "median_weights",
    },
    "improved": {
        "profile",
        "radius_factor",
        "level",
        "guard_factor",
        "guard_margin",
        "refinement",
        "max_refinement",
        "saddle_rule",
        "narrow_band",
        "band_margin",
        "root_tolerance",
        "curvature_correction",
        "mirror_grid_edges",
        "neighbour_shape",
        "max_stretch",
        "spurious_loops",
    },
    "smm": {"marker_spacing", "initial_contour", "massless_nodes"},
    "vof": {"refinement", "fraction", "mixed_tolerance"},
    "density": {"field", "threshold", "refinement"},
}


def _read_detection(d, file, pointer):
    """The detection block: its keys are checked (so typos are refused as by the C++ reader),
    its values only for every_steps and method."""
    _expect_object(d, file, pointer, {"every_steps", "method", *DETECTOR_KEYS})
    _int(d, "every_steps", file, pointer, 1, 1, 2**31 - 1)
    _choice(d, "method", file, pointer, tuple(DETECTOR_KEYS), default="improved")
    for name, keys in DETECTOR_KEYS.items():
        if name in d:
            _expect_object(d[name], file, f"{pointer}/{name}", keys)


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
    _expect_object(
        root,
        file,
        "",
        {
            "title",
            "grid",
            "materials",
            "bodies",
            "gravity",
            "initial_stress",
            "node_sets",
            "boundary_conditions",
            "loads",
            "solver",
            "time",
            "output",
            "detection",
            "manufactured_solution",
        },
    )
    if "manufactured_solution" in root:
        _fail(
            file,
            "/manufactured_solution",
            "the dolfinx model has no manufactured body force (run it on pfm-mpm, MPM or "
            "UL-FEM)",
        )
    ignored = []
    title = root.get("title", "")
    if not isinstance(title, str):
        _fail(file, "/title", "must be a string")
    if "grid" not in root:
        _fail(file, "/grid", "missing key")
    grid = root["grid"]
    _expect_object(grid, file, "/grid", {"origin", "cell_size", "n_cells", "max_nodes"})
    node_count = dict(check=lambda v: 1 <= v <= 2e9, what="must be in [1, 2e9]")
    _number(grid, "max_nodes", file, "/grid", default=1e7, **node_count)
    if "max_nodes" in grid:
        ignored.append("/grid/max_nodes: the MPM's grid only")
    origin = _point(grid.get("origin", [0, 0]), file, "/grid/origin")
    cell_size = _number(grid, "cell_size", file, "/grid", required=True, rule=_POSITIVE)
    if "n_cells" not in grid:
        _fail(file, "/grid/n_cells", "missing key")
    nc = grid["n_cells"]
    if not (
        isinstance(nc, list)
        and len(nc) == 2
        and all(isinstance(n, int) and not isinstance(n, bool) and n >= 1 for n in nc)
    ):
        _fail(file, "/grid/n_cells", "must be [nx, ny], integers >= 1")

    if not isinstance(root.get("materials"), list) or not root["materials"]:
        _fail(file, "/materials", "must be a non-empty list")
    materials = {}
    for k, m in enumerate(root["materials"]):
        p = f"/materials/{k}"
        if not isinstance(m, dict):
            _fail(file, p, "must be an object")
        model = _choice(
            m,
            "model",
            file,
            p,
            ("linear_elastic", "tresca", "mohr_coulomb"),
            required=True,
        )
        keys = {"name", "model", "youngs_modulus", "poisson_ratio", "unit_weight"}
        if model != "linear_elastic":
            keys |= {"cohesion", "softening_length"}
        if model == "mohr_coulomb":
            keys |= {"friction_angle", "dilation_angle", "tension_cutoff"}
        # as the C++ reader: keys of other models are unknown
        _expect_object(m, file, p, keys)
        name = m.get("name")
        if not isinstance(name, str) or not name or name in materials:
            _fail(file, p + "/name", "must be a unique non-empty string")
        mat = Material(
            name,
            model,
            _number(m, "youngs_modulus", file, p, required=True, rule=_POSITIVE),
            _number(
                m,
                "poisson_ratio",
                file,
                p,
                required=True,
                check=lambda v: 0 <= v < 0.5,
                what="must be in [0, 0.5)",
            ),
            _number(m, "unit_weight", file, p, required=True, rule=_NON_NEGATIVE),
        )
        if model != "linear_elastic":
            if "cohesion" not in m:
                _fail(file, p + "/cohesion", "missing key")
            mat.cohesion = _read_cohesion(m["cohesion"], file, p + "/cohesion")
            if "softening_length" in m:
                mat.softening_length = _number(
                    m, "softening_length", file, p, required=True, rule=_POSITIVE
                )
                if len(mat.cohesion.x) < 2:
                    _fail(
                        file,
                        p + "/softening_length",
                        "needs a cohesion that changes with the plastic strain",
                    )
        if model == "mohr_coulomb":
            mat.friction_angle = _number(
                m,
                "friction_angle",
                file,
                p,
                required=True,
                check=lambda v: 0 <= v < 90,
                what="must be in [0, 90)",
            )
            mat.dilation_angle = _number(
                m,
                "dilation_angle",
                file,
                p,
                default=0.0,
                check=lambda v: 0 <= v <= mat.friction_angle,
                what="must be in [0, friction_angle]",
            )
            c0 = mat.cohesion.y[0]
            phi = math.radians(mat.friction_angle)
            default_cut = c0 / math.tan(phi) if mat.friction_angle > 0 else 0.0
            mat.tension_cutoff = _number(
                m, "tension_cutoff", file, p, default=default_cut, rule=_NON_NEGATIVE
            )
        materials[name] = mat

    if not isinstance(root.get("bodies"), list) or not root["bodies"]:
        _fail(file, "/bodies", "must be a non-empty list")
    bodies = []
    for k, b in enumerate(root["bodies"]):
        p = f"/bodies/{k}"
        _expect_object(
            b,
            file,
            p,
            {
                "name",
                "material",
                "rectangle",
                "polygon",
                "mesh",
                "physical_group",
                "points_per_cell",
                "placement",
            },
        )
        _int(b, "points_per_cell", file, p, 2, 1, 8)
        _choice(b, "placement", file, p, ("equal", "gauss", "conforming"))
        for key in ("points_per_cell", "placement"):
            if key in b:
                ignored.append(f"{p}/{key}: MPM material points only")
        if b.get("material") not in materials:
            _fail(file, p + "/material", "must name a material")
        if sum(key in b for key in ("rectangle", "polygon", "mesh")) != 1:
            _fail(file, p, "needs exactly one of rectangle, polygon, mesh")
        if "physical_group" in b and "mesh" not in b:
            _fail(file, p + "/physical_group", 'used only with "mesh" (a gmsh file)')
        if "mesh" in b:
            # The outline of the file's 2D elements, as the C++ reader's body polygon
            # (mpm/solver/gmsh_surface.hpp); the model meshes it with its own elements.
            path = Path(b["mesh"])
            if not path.is_absolute():
                path = Path(file).parent / path
            poly = _mesh_outline(path, b.get("physical_group", ""), file, p + "/mesh")
        elif "rectangle" in b:
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
            if len(poly) > 3 and poly[0] == poly[-1]:
                poly = poly[:-1]  # closed form, as the C++ reader
            try:
                poly = _ccw(poly)
            except ValueError:
                _fail(file, p + "/polygon", "has zero area")
        bodies.append(Body(b.get("name", f"body{k}"), b["material"], poly))

    gravity = root.get("gravity", {})
    _expect_object(gravity, file, "/gravity", {"g", "ramp_time"})
    g = _number(gravity, "g", file, "/gravity", default=9.81, rule=_NON_NEGATIVE)
    ramp = _number(
        gravity, "ramp_time", file, "/gravity", default=0.0, rule=_NON_NEGATIVE
    )

    ini = root.get("initial_stress", {})
    _expect_object(
        ini,
        file,
        "/initial_stress",
        {"method", "k0", "kinetic_energy_ratio", "damping", "max_time"},
    )
    method = ini.get("method", "zero")
    if method not in ("zero", "k0", "gravity"):
        _fail(file, "/initial_stress/method", "must be zero, k0 or gravity")
    k0 = _number(ini, "k0", file, "/initial_stress", default=None, rule=_NON_NEGATIVE)
    if k0 is not None and method != "k0":
        _fail(file, "/initial_stress/k0", 'only used with method "k0"')
    for key, check, what in (
        ("kinetic_energy_ratio", lambda v: 0 < v < 1, "must be in (0, 1)"),
        ("damping", lambda v: 0 <= v < 1, "must be in [0, 1)"),
        ("max_time", lambda v: v > 0, "must be > 0"),
    ):
        if key in ini:
            if method != "gravity":
                _fail(file, f"/initial_stress/{key}", 'only used with method "gravity"')
            _number(ini, key, file, "/initial_stress", check=check, what=what)
            ignored.append(
                f"/initial_stress/{key}: dynamic (MPM, UL-FEM) gravity procedure "
                "only; the dolfinx model loads gravity statically"
            )

    node_sets = {}
    for k, ns in enumerate(root.get("node_sets", [])):
        p = f"/node_sets/{k}"
        _expect_object(ns, file, p, {"name", "box"})
        box = ns.get("box")
        if not isinstance(box, list) or len(box) != 2:
            _fail(file, p + "/box", "must be [[x0, y0], [x1, y1]]")
        node_sets[ns.get("name")] = (
            _point(box[0], file, p + "/box/0"),
            _point(box[1], file, p + "/box/1"),
        )

    bcs = []
    for k, bc in enumerate(root.get("boundary_conditions", [])):
        p = f"/boundary_conditions/{k}"
        _expect_object(bc, file, p, {"where", "fix"})
        where = bc.get("where")
        if where not in ("left", "right", "bottom", "top") and where not in node_sets:
            _fail(
                file,
                p + "/where",
                "must be left, right, bottom, top or a node-set name",
            )
        if bc.get("fix") not in ("x", "y", "xy"):
            _fail(file, p + "/fix", "must be x, y or xy")
        bcs.append((where, bc["fix"]))

    loads = []
    loads_list = root.get("loads", [])
    if not isinstance(loads_list, list):
        _fail(file, "/loads", "must be a list")
    for k, ld in enumerate(loads_list):
        loads.append(_read_load(ld, file, f"/loads/{k}", ignored))

    solver = root.get("solver", {})
    _expect_object(
        solver,
        file,
        "/solver",
        {
            "scheme",
            "shape_function",
            "damping",
            "damping_form",
            "pic_fraction",
            "anti_locking",
        },
    )
    _choice(solver, "damping_form", file, "/solver", ("per_axis", "along_velocity"))
    if solver.get("damping_form", "per_axis") != "per_axis":
        ignored.append(
            "/solver/damping_form: the explicit dolfinx model damps per axis"
        )
    _choice(solver, "scheme", file, "/solver", ("musl", "usl"))
    _choice(
        solver,
        "shape_function",
        file,
        "/solver",
        ("linear", "gimp", "quadratic_bspline", "cubic_bspline"),
    )
    _choice(solver, "anti_locking", file, "/solver", ("none", "bbar"))
    _number(
        solver,
        "pic_fraction",
        file,
        "/solver",
        default=0.0,
        check=lambda v: 0 <= v <= 1,
        what="must be in [0, 1] (0 = FLIP, 1 = PIC)",
    )
    for key in ("scheme", "shape_function", "pic_fraction"):
        if key in solver:
            ignored.append(f"/solver/{key}: MPM only")
    if "anti_locking" in solver:
        ignored.append(
            "/solver/anti_locking: MPM and UL-FEM only (the dolfinx model does not average "
            "the dilatation)"
        )
    damping = _number(
        solver,
        "damping",
        file,
        "/solver",
        default=0.0,
        check=lambda v: 0 <= v < 1,
        what="must be in [0, 1)",
    )
    if "time" not in root:
        _fail(file, "/time", "missing key")
    tm = root["time"]
    _expect_object(tm, file, "/time", {"end_time", "cfl", "dt", "max_steps"})
    end_time = _number(tm, "end_time", file, "/time", required=True, rule=_POSITIVE)
    cfl = _number(
        tm,
        "cfl",
        file,
        "/time",
        default=0.5,
        check=lambda v: 0 < v <= 1,
        what="must be in (0, 1]",
    )
    dt = _number(tm, "dt", file, "/time", default=None, rule=_POSITIVE)
    output = root.get("output", {})
    _expect_object(
        output,
        file,
        "/output",
        {"interval", "timeseries_interval", "nodal_loads", "compression"},
    )
    _choice(output, "compression", file, "/output", ("none", "gzip"))
    _number(output, "interval", file, "/output", rule=_POSITIVE)
    _number(output, "timeseries_interval", file, "/output", rule=_POSITIVE)
    _bool(output, "nodal_loads", file, "/output", False)
    for key in output:
        ignored.append(
            f"/output/{key}: MPM output setting (the dolfinx outputs are set on the "
            "command line)"
        )

    detection = None
    if "detection" in root:
        detection = root["detection"]
        _read_detection(detection, file, "/detection")
        ignored.append(
            "/detection: boundary detection is not needed, the finite element "
            "boundary is exact"
        )

    return Case(
        file,
        title,
        origin,
        cell_size,
        tuple(nc),
        materials,
        bodies,
        g,
        ramp,
        method,
        k0,
        node_sets,
        bcs,
        loads,
        damping,
        end_time,
        cfl,
        dt,
        raw=root,
        detection=detection,
        ignored=ignored,
    )
