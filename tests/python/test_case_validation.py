"""Malformed case files: each exits with code 2, names the file and the JSON pointer of the
bad value, and leaves no output directory behind (issue: MPM core, item 7)."""
import copy
import json
import math
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
BASE = json.loads(
    (ROOT / "cases" / "thesis62_bearing_dynamic_zero_start.json").read_text()
)


def mutate(path, value=None, delete=False):
    """Return a copy of the base case with the value at `path` (list of keys) replaced."""
    case = copy.deepcopy(BASE)
    node = case
    for key in path[:-1]:
        node = node[key]
    if delete:
        del node[path[-1]]
    else:
        node[path[-1]] = value
    return case


def bspline_with(path, value):
    """The base case with cubic B-splines and the value at `path` replaced."""
    case = mutate(path, value)
    case["solver"]["shape_function"] = "cubic_bspline"
    return case


def without_shape_function(path, value):
    """The base case with the value at `path` replaced and no shape function: the default,
    quadratic B-splines."""
    case = mutate(path, value)
    del case["solver"]["shape_function"]
    return case


def elastic_with(key, value):
    """The base case with its soil linear elastic (as a manufactured solution needs) and
    `key` set to `value`."""
    case = mutate([key], value)
    case["materials"][0] = {
        "name": "soil",
        "model": "linear_elastic",
        "youngs_modulus": 1000.0,
        "poisson_ratio": 0.15,
        "unit_weight": 20.0,
    }
    return case


# (name, case document or raw text, JSON pointer expected in the message)
MALFORMED = [
    (
        "negative_modulus",
        mutate(["materials", 0, "youngs_modulus"], -5.0),
        "/materials/0/youngs_modulus",
    ),
    (
        "zero_modulus",
        mutate(["materials", 0, "youngs_modulus"], 0.0),
        "/materials/0/youngs_modulus",
    ),
    (
        "modulus_string",
        mutate(["materials", 0, "youngs_modulus"], "1000"),
        "/materials/0/youngs_modulus",
    ),
    (
        "poisson_half",
        mutate(["materials", 0, "poisson_ratio"], 0.5),
        "/materials/0/poisson_ratio",
    ),
    (
        "missing_modulus",
        mutate(["materials", 0, "youngs_modulus"], delete=True),
        "/materials/0",
    ),
    (
        "unknown_material_key",
        mutate(["materials", 0, "colour"], "red"),
        "/materials/0/colour",
    ),
    ("unknown_top_key", mutate(["solverr"], {}), "/solverr"),
    (
        "unknown_model",
        mutate(["materials", 0, "model"], "cam_clay"),
        "/materials/0/model",
    ),
    (
        "cohesion_negative",
        mutate(["materials", 0, "cohesion"], -1.0),
        "/materials/0/cohesion",
    ),
    (
        "softening_breakpoints_reversed",
        mutate(["materials", 0, "cohesion", "residual_plastic_strain"], 0.01),
        "/materials/0/cohesion/residual_plastic_strain",
    ),
    ("missing_grid", mutate(["grid"], delete=True), '/: missing key "grid"'),
    ("cell_size_zero", mutate(["grid", "cell_size"], 0), "/grid/cell_size"),
    ("n_cells_fraction", mutate(["grid", "n_cells"], [30.5, 15]), "/grid/n_cells/0"),
    ("n_cells_one_entry", mutate(["grid", "n_cells"], [30]), "/grid/n_cells"),
    (
        "polygon_outside_grid",
        mutate(["bodies", 0, "rectangle"], [[0, 0], [20, 5]]),
        "/bodies/0/rectangle",
    ),
    ("empty_bodies", mutate(["bodies"], []), "/bodies"),
    (
        "body_unknown_material",
        mutate(["bodies", 0, "material"], "clay"),
        "/bodies/0/material",
    ),
    (
        "self_intersecting_polygon",
        mutate(
            ["bodies", 0],
            {
                "name": "bow",
                "material": "soil",
                "polygon": [[1, 1], [5, 4], [5, 1], [1, 4]],
            },
        ),
        "/bodies/0/polygon",
    ),
    (
        "polygon_two_vertices",
        mutate(
            ["bodies", 0],
            {"name": "line", "material": "soil", "polygon": [[1, 1], [5, 4]]},
        ),
        "/bodies/0/polygon",
    ),
    (
        "both_rectangle_and_polygon",
        mutate(["bodies", 0, "polygon"], [[1, 1], [5, 1], [5, 4]]),
        "/bodies/0",
    ),
    (
        "points_per_cell_zero",
        mutate(["bodies", 0, "points_per_cell"], 0),
        "/bodies/0/points_per_cell",
    ),
    (
        "placement_unknown",
        mutate(["bodies", 0, "placement"], "random"),
        "/bodies/0/placement",
    ),
    (
        "bc_unknown_place",
        mutate(["boundary_conditions", 0, "where"], "middle"),
        "/boundary_conditions/0/where",
    ),
    (
        "bc_bad_fix",
        mutate(["boundary_conditions", 0, "fix"], "z"),
        "/boundary_conditions/0/fix",
    ),
    (
        "load_range_reversed",
        mutate(["loads", 0, "x_range"], [10, 5]),
        "/loads/0/x_range",
    ),
    (
        "load_negative_pressure",
        mutate(["loads", 0, "pressure"], -50),
        "/loads/0/pressure",
    ),
    ("end_time_negative", mutate(["time", "end_time"], -1), "/time/end_time"),
    ("missing_time", mutate(["time"], delete=True), '/: missing key "time"'),
    ("cfl_above_one", mutate(["time", "cfl"], 1.5), "/time/cfl"),
    ("dt_above_critical", mutate(["time", "dt"], 1.0), "/time/dt"),
    ("scheme_unknown", mutate(["solver", "scheme"], "usf"), "/solver/scheme"),
    ("damping_one", mutate(["solver", "damping"], 1.0), "/solver/damping"),
    # 0 and 9: outside [1, 8]; 1.5: not an integer; 2: the case names no pic_fraction.
    *[
        (
            f"xpic_order_{value}",
            mutate(["solver", "xpic_order"], value),
            "/solver/xpic_order",
        )
        for value in (0, 1.5, 9, 2)
    ],
    (
        "k0_with_zero_method",
        mutate(["initial_stress", "k0"], 0.5),
        "/initial_stress/k0",
    ),
    ("huge_number", None, "number overflow parsing '1e999'"),  # no inf in JSON
    (
        "unknown_anti_locking",
        mutate(["solver", "anti_locking"], "fbar"),
        "/solver/anti_locking",
    ),
    (
        "manufactured_negative_amplitude",
        elastic_with("manufactured_solution", {"amplitude": -1e-5, "period": 0.1}),
        "/manufactured_solution/amplitude",
    ),
    (
        "manufactured_on_plastic_soil",
        mutate(["manufactured_solution"], {"amplitude": 1e-5, "period": 0.1}),
        "/bodies/0/material",
    ),
    (
        "dilatation_without_its_pressure",
        elastic_with("manufactured_solution", {"type": "uniform_dilatation"}),
        "/manufactured_solution",
    ),
    (
        "smooth_ramp_without_time",
        mutate(["loads", 0, "time_function"], {"type": "smooth_ramp"}),
        "/loads/0/time_function",
    ),
    (
        "softening_length_not_positive",
        mutate(["materials", 0, "softening_length"], 0.0),
        "/materials/0/softening_length",
    ),
    (
        "softening_length_on_a_constant_cohesion",
        mutate(
            ["materials", 0],
            dict(BASE["materials"][0], cohesion=20.0, softening_length=0.5),
        ),
        "/materials/0/softening_length",
    ),
    (
        "unknown_shape_function",
        mutate(["solver", "shape_function"], "quartic_bspline"),
        "/solver/shape_function",
    ),
    (
        "cubic_bspline_on_two_cells",
        bspline_with(
            ["grid"], {"origin": [0.0, 0.0], "cell_size": 7.5, "n_cells": [2, 2]}
        ),
        "/solver/shape_function",
    ),
    (
        "default_bsplines_on_one_cell_row",
        without_shape_function(
            ["grid"], {"origin": [0.0, 0.0], "cell_size": 15.0, "n_cells": [1, 1]}
        ),
        "/grid/n_cells",
    ),
    (
        "bspline_gauss_points_past_the_table",
        bspline_with(["loads", 0, "gauss_points"], 15),
        "/loads/0/gauss_points",
    ),
    ("truncated_json", "TRUNCATED", "invalid JSON"),
    ("empty_file", "", "file is empty"),
    ("not_an_object", "[1, 2, 3]", "expected an object"),
]


def write_case(tmp_path: Path, name: str, document) -> Path:
    path = tmp_path / f"{name}.json"
    if name == "huge_number":
        text = json.dumps(BASE).replace(
            '"youngs_modulus": 1000.0', '"youngs_modulus": 1e999'
        )
        assert "1e999" in text
        path.write_text(text)
    elif document == "TRUNCATED":
        text = json.dumps(BASE)
        path.write_text(text[: len(text) // 2])
    elif isinstance(document, str):
        path.write_text(document)
    else:
        path.write_text(json.dumps(document))
    return path


def test_there_are_at_least_twenty_malformed_cases():
    assert len(MALFORMED) >= 20


@pytest.mark.parametrize(
    "name,document,pointer", MALFORMED, ids=[m[0] for m in MALFORMED]
)
def test_malformed_case_exits_2_naming_the_json_pointer(
    tmp_path, pfm_binary, name, document, pointer
):
    case = write_case(tmp_path, name, document)
    out = tmp_path / "out"
    result = subprocess.run(
        [str(pfm_binary), "run", str(case), "--out", str(out), "--quiet"],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert result.returncode == 2, result.stderr
    assert str(case) in result.stderr, result.stderr
    assert pointer in result.stderr, result.stderr
    assert not out.exists(), "an output directory was left behind"


def test_valid_shipped_cases_validate(pfm_binary):
    for case in sorted((ROOT / "cases").glob("*.json")):
        result = subprocess.run(
            [str(pfm_binary), "validate", str(case)],
            capture_output=True,
            text=True,
            timeout=60,
        )
        assert result.returncode == 0, f"{case}: {result.stderr}"


def test_output_directory_of_foreign_content_is_refused(tmp_path, pfm_binary):
    out = tmp_path / "precious"
    out.mkdir()
    (out / "thesis.tex").write_text("do not delete")
    result = subprocess.run(
        [
            str(pfm_binary),
            "run",
            str(ROOT / "cases" / "column.json"),
            "--out",
            str(out),
            "--quiet",
        ],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert result.returncode == 2
    assert (out / "thesis.tex").read_text() == "do not delete"


def test_run_writes_provenance_and_outputs(tmp_path, pfm_binary):
    out = tmp_path / "column"
    case = ROOT / "cases" / "column.json"
    result = subprocess.run(
        [str(pfm_binary), "run", str(case), "--out", str(out), "--quiet"],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert result.returncode == 0, result.stderr
    run = json.loads((out / "run.json").read_text())
    assert run["status"] == "completed"
    assert run["provenance"]["git_revision"] != ""
    assert run["provenance"]["build_type"] in (
        "Release",
        "Sanitize",
        "Debug",
        "RelWithDebInfo",
    )
    assert run["case"] == json.loads(case.read_text())
    summary = run["summary"]
    for key in ("n_particles", "n_steps", "wall_time_s", "particle_steps_per_s"):
        assert key in summary
    assert summary["n_particles"] == 2 * 2 * 2 * 10  # 2 x 10 cells, 2 x 2 points each
    header = (out / "final_particles.csv").read_text().splitlines()[0]
    assert header.startswith("id,x,y,vx,vy,sxx,syy,sxy,szz,eps_p,volume")
    series = (out / "timeseries.csv").read_text().splitlines()
    assert series[0].startswith("time,kinetic_energy,external_work")
    # The final time reaches end_time (4 s) within one step.
    last_time = float(series[-1].split(",")[0])
    assert abs(last_time - 4.0) <= summary["dt_s"]
    assert (out / "particles.h5").exists() and (out / "particles.xdmf").exists()


def test_xdmf_series_opens_with_meshio(tmp_path, pfm_binary):
    meshio = pytest.importorskip("meshio")
    out = tmp_path / "column"
    subprocess.run(
        [
            str(pfm_binary),
            "run",
            str(ROOT / "cases" / "column.json"),
            "--out",
            str(out),
            "--quiet",
        ],
        check=True,
        capture_output=True,
        timeout=120,
    )
    with meshio.xdmf.TimeSeriesReader(str(out / "particles.xdmf")) as reader:
        points, cells = reader.read_points_cells()
        n_steps = reader.num_steps
        t, point_data, _ = reader.read_data(n_steps - 1)
    assert points.shape == (80, 3)
    assert n_steps >= 2
    assert math.isclose(t, 4.0, abs_tol=0.01)
    assert point_data["syy"].shape == (80,)
    # Self-weight: the deepest particles carry about gamma * H = 100 kPa (compression negative).
    assert -110.0 < point_data["syy"].min() < -90.0


def test_particle_leaving_the_grid_stops_with_exit_3_and_keeps_output(
    tmp_path, pfm_binary
):
    """A block with no support falls out of the bottom of the grid: the run stops with exit 3,
    says which particle left and when, marks run.json failed and keeps the steps written.
    """
    case = json.loads((ROOT / "cases" / "column.json").read_text())
    case["boundary_conditions"] = []
    case["gravity"] = {"g": 9.81}
    case["solver"]["damping"] = 0.0  # local damping would slow the fall
    case["time"]["end_time"] = 2.0
    case["output"] = {"interval": 0.05}
    path = tmp_path / "falling.json"
    path.write_text(json.dumps(case))
    out = tmp_path / "falling"
    result = subprocess.run(
        [str(pfm_binary), "run", str(path), "--out", str(out), "--quiet"],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert result.returncode == 3, result.stderr
    assert "has left the grid" in result.stderr
    run = json.loads((out / "run.json").read_text())
    assert run["status"] == "failed" and "left the grid" in run["error"]
    # Free fall from rest: the lowest particle (y = 0.125 m) leaves after sqrt(2 * 0.125 / g).
    t_exit = math.sqrt(2 * 0.125 / 9.81)
    assert run["summary"]["final_time_s"] == pytest.approx(
        t_exit, abs=2 * run["summary"]["dt_s"]
    )
    assert (out / "particles.xdmf").exists()
    assert not (out / "final_particles.csv").exists()


@pytest.mark.parametrize("threads", ["x", "-1", "2x", "--out"])
def test_ulfem_driver_refuses_a_bad_thread_count(tmp_path, pfm_binary, threads):
    """pfm-ulfem CASE OUT [THREADS]: a THREADS that is not a whole number >= 0 is bad input
    (exit 2 naming THREADS and the value), not an uncaught exception (it was one: std::stoi
    threw on "--out"); nothing is written."""
    case = tmp_path / "case.json"
    case.write_text(json.dumps(BASE))
    out = tmp_path / "out"
    result = subprocess.run(
        [str(pfm_binary.parent / "pfm-ulfem"), str(case), str(out), threads],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert result.returncode == 2, result.stderr
    assert f"THREADS: expected a whole number >= 0 (0: all cores), got '{threads}'" in (
        result.stderr
    )
    assert not out.exists()
