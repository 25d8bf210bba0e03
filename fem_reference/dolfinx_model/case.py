"""Reading of the project's case JSON files (schema: README.md, "Case-file reference").

The C++ reader validates every case (the one schema, through the Python module pfm_mpm on the
C++ core: python/README.md) and resolves it (defaults applied, rectangles and gmsh meshes as
counter-clockwise polygons); this module turns the resolved case into the dataclasses of the
finite element model. Bad input raises CaseError with the C++ message (the file and the JSON
pointer). Keys that matter to the MPM only (points_per_cell, placement, solver.scheme /
shape_function, output, the detection block, the discrete boundary integration of
detected-boundary loads) are listed in Case.ignored with the reason.
"""
from __future__ import annotations

import dataclasses
import json
import math
import os
import sys
from dataclasses import dataclass, field
from pathlib import Path
from typing import Optional


def _core():
    """The module pfm_mpm: importable as is, or from the build after `make build`: the folder
    python/ of $PFM_BUILD_DIR (the build root or its bin/) or of <repository>/build."""
    try:
        import pfm_mpm
    except ImportError:
        roots = [Path(__file__).parents[2] / "build"]
        if "PFM_BUILD_DIR" in os.environ:
            build = Path(os.environ["PFM_BUILD_DIR"])
            roots[:0] = [build, build.parent]
        for root in roots:
            if (root / "python" / "pfm_mpm").is_dir():
                sys.path.append(str(root / "python"))
                break
        try:
            import pfm_mpm
        except ImportError as err:
            raise ImportError(
                f"the module pfm_mpm is not built ({err}): run `make build`, or put "
                "<build>/python on PYTHONPATH (python/README.md)"
            ) from err
    return pfm_mpm


class CaseError(ValueError):
    """Bad case file: '<file>: <pointer>: <message>'."""


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

    def reduced(self, factor: float) -> "Material":
        """This material with its strength divided by `factor`, as the C++ reduced_strength
        (mpm/core/materials.hpp): every cohesion of the law, tan(phi), tan(psi) and the tension
        cut-off over factor; the elastic parameters kept."""
        if self.model == "linear_elastic":
            return self

        def angle(deg):
            return math.degrees(math.atan(math.tan(math.radians(deg)) / factor))

        return dataclasses.replace(
            self,
            cohesion=Cohesion(self.cohesion.x, [y / factor for y in self.cohesion.y]),
            friction_angle=angle(self.friction_angle),
            dilation_angle=angle(self.dilation_angle),
            tension_cutoff=(
                None if self.tension_cutoff is None else self.tension_cutoff / factor
            ),
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
class Support:
    """A boundary condition: the components `fix` ("x", "y" or "xy") of the nodes on `where`
    (left, right, bottom, top or a node-set name) are held, at zero displacement, or moved with
    `velocity` (m/s, of the fixed components) times the time function (a moving support: the
    static analysis prescribes its displacement, `velocity` times the time function's integral).
    """

    where: str
    fix: str
    velocity: Optional[tuple] = None
    time_function: dict = field(default_factory=lambda: {"type": "constant"})

    def displacement(self, t: float):
        """m: the support's displacement at time t, (ux, uy) (zero if it does not move)."""
        if self.velocity is None:
            return (0.0, 0.0)
        return tuple(v * time_integral(self.time_function, t) for v in self.velocity)


def time_function_factor(tf: dict, t: float) -> float:
    """The time function's factor at time t (as TimeFunction::factor, mpm/step/case.hpp):
    1 (constant), t / t_r (ramp) or 10 u^3 - 15 u^4 + 6 u^5 with u = t / t_r (smooth ramp), and
    1 after t_r."""
    ramp = tf.get("ramp_time", 0.0)
    if tf.get("type", "constant") == "constant" or ramp <= 0.0 or t >= ramp:
        return 1.0
    u = t / ramp
    return (
        u**3 * (10.0 - 15.0 * u + 6.0 * u * u) if tf["type"] == "smooth_ramp" else u
    )


def time_integral(tf: dict, t: float) -> float:
    """s: the integral of the time function's factor from 0 to t (a moving support's
    displacement per unit velocity): t, then t - t_r / 2 after a ramp of t_r."""
    ramp = tf.get("ramp_time", 0.0)
    if tf.get("type", "constant") == "constant" or ramp <= 0.0 or t >= ramp:
        return t - (0.5 * ramp if tf.get("type", "constant") != "constant" else 0.0)
    u = t / ramp
    if tf["type"] == "smooth_ramp":
        return ramp * u**4 * (2.5 - 3.0 * u + u * u)
    return 0.5 * ramp * u * u


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
    node_sets: dict  # name -> box ((x0, y0), (x1, y1)) or {"segments": (k, 2, 2)}
    boundary_conditions: list  # [Support]
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


def read_case(path: str) -> Case:
    """Read and validate a case file; raises CaseError."""
    file = str(path)
    try:
        with open(file) as f:
            root = json.load(f)
    except (OSError, json.JSONDecodeError) as err:
        raise CaseError(f"{file}: cannot read JSON: {err}") from err
    return case_from_dict(root, file)


def _ignored(root: dict) -> list:
    """["/json/pointer: why the finite element model does not use it", ...]"""
    out = []
    if "max_nodes" in root.get("grid", {}):
        out.append("/grid/max_nodes: the MPM's grid only")
    for k, body in enumerate(root["bodies"]):
        for key in ("points_per_cell", "placement"):
            if key in body:
                out.append(f"/bodies/{k}/{key}: MPM material points only")
    for key in ("kinetic_energy_ratio", "damping", "max_time"):
        if key in root.get("initial_stress", {}):
            out.append(
                f"/initial_stress/{key}: dynamic (MPM, UL-FEM) gravity procedure "
                "only; the dolfinx model loads gravity statically"
            )
    for k, load in enumerate(root.get("loads", [])):
        for key in MPM_INTEGRATION_KEYS:
            if key in load:
                out.append(
                    f"/loads/{k}/{key}: MPM boundary integration only (the finite element "
                    "integrates the traction exactly on the mesh boundary)"
                )
    solver = root.get("solver", {})
    if (
        solver.get("damping", 0.0) > 0.0
        and solver.get("damping_form", "along_velocity") != "per_axis"
    ):
        out.append("/solver/damping_form: the explicit dolfinx model damps per axis")
    for key in ("scheme", "shape_function", "pic_fraction", "xpic_order"):
        if key in solver:
            out.append(f"/solver/{key}: MPM only")
    if "anti_locking" in solver:
        out.append(
            "/solver/anti_locking: MPM and UL-FEM only (the dolfinx model does not average "
            "the dilatation)"
        )
    for key in root.get("output", {}):
        out.append(
            f"/output/{key}: MPM output setting (the dolfinx outputs are set on the "
            "command line)"
        )
    if "detection" in root:
        out.append(
            "/detection: boundary detection is not needed, the finite element "
            "boundary is exact"
        )
    return out


def _material(m: dict) -> Material:
    out = Material(
        m["name"], m["model"], m["youngs_modulus"], m["poisson_ratio"], m["unit_weight"]
    )
    if m["model"] != "linear_elastic":
        law = m["cohesion"]
        out.cohesion = Cohesion(law["plastic_strain"], law["cohesion"])
        out.softening_length = m["softening_length"]
    if m["model"] == "mohr_coulomb":
        out.friction_angle = m["friction_angle"]
        out.dilation_angle = m["dilation_angle"]
        cutoff = m["tension_cutoff"]  # null: none besides the apex c cot(phi)
        out.tension_cutoff = math.inf if cutoff is None else cutoff
    return out


def _node_set(s: dict):
    """((x0, y0), (x1, y1)), a closed box; or {"segments": array (k, 2, 2)}, the line
    elements and points of a gmsh physical group."""
    if s["box"] is not None:
        return tuple(map(tuple, s["box"]))
    import numpy as np

    return {"segments": np.array(s["segments"], dtype=float).reshape(-1, 2, 2)}


def _load(ld: dict) -> Load:
    x_range, traction = ld["x_range"], ld["traction"]
    return Load(
        ld["pressure"],
        None if x_range is None else tuple(x_range),
        ld["time_function"],
        type=ld["type"],
        traction=None if traction is None else tuple(traction),
        faces=ld["faces"],
        interval=ld["interval"],
        apply_on=ld["apply_on"],
    )


def case_from_dict(root: dict, file: str = "<dict>") -> Case:
    """The case of the document ``root`` (as read from ``file``, which names it in messages
    and resolves the relative paths of mesh files), validated by the C++ reader."""
    core = _core()
    try:
        c = core.parse_case(root, file)
    except core.InputError as err:
        raise CaseError(str(err)) from err
    if c["manufactured_solution"]:
        raise CaseError(
            f"{file}: /manufactured_solution: the dolfinx model has no manufactured body "
            "force (run it on pfm-mpm, MPM or UL-FEM)"
        )
    if c["constraints"]:
        raise CaseError(
            f"{file}: /constraints: the dolfinx model prescribes displacements on mesh "
            "nodes only (a constraint on a detected boundary is the MPM's)"
        )
    for k, load in enumerate(c["loads"]):
        if "normal" in load:
            raise CaseError(
                f"{file}: /loads/{k}/normal: the dolfinx model selects a load's faces by "
                "x_range and faces only"
            )
    materials = {m["name"]: _material(m) for m in c["materials"]}
    bodies = []
    for k, b in enumerate(c["bodies"]):
        if b["source"] == "particles":
            raise CaseError(
                f"{file}: /bodies/{k}/particles: the dolfinx model meshes a polygon, "
                "rectangle or mesh body, not a particle file"
            )
        name = c["materials"][b["material"]]["name"]
        bodies.append(Body(b["name"], name, [tuple(v) for v in b["polygon"]]))
    stress = c["initial_stress"]
    return Case(
        file,
        c["title"],
        tuple(c["grid"]["origin"]),
        c["grid"]["cell_size"],
        tuple(c["grid"]["n_cells"]),
        materials,
        bodies,
        c["gravity"]["g"],
        c["gravity"]["ramp_time"],
        stress["method"],
        stress["k0"],
        {s["name"]: _node_set(s) for s in c["node_sets"]},
        [
            Support(
                bc["where"],
                bc["fix"],
                None if bc["velocity"] is None else tuple(bc["velocity"]),
                bc["time_function"],
            )
            for bc in c["boundary_conditions"]
        ],
        [_load(ld) for ld in c["loads"]],
        c["solver"]["damping"],
        c["time"]["end_time"],
        c["time"]["cfl"],
        c["time"]["dt"],
        raw=root,
        detection=root.get("detection"),
        ignored=_ignored(root),
    )
