"""`pfm-mpm run` of a case with solver.type "implicit" (mpm/implicit/implicit_run.hpp): the files
of a completed run and what they say, the stop of a step that cannot converge (exit 3, the
outputs so far kept), and the refusals (exit 2 naming the JSON path, nothing created). The
solver's physics is checked in tests/cpp/implicit/test_implicit_solver.cpp."""

import csv
import json
import math

import h5py
import pytest

from studies.stability import column_surcharge_case

# E = 5e5 kPa, nu = 0.25: M = 6e5 kPa; unit weight 18 kN/m^3, H = 4 m, q = 30 kPa.
MODULUS, HEIGHT, WEIGHT, SURCHARGE = 6e5, 4.0, 18.0, 30.0


def column(load_steps=4):
    """The stability study's column (studies.stability.column_surcharge_case), stiffer (strains of
    1e-4, where the small-strain closed form holds), on the implicit solver."""
    case = column_surcharge_case()
    case["materials"][0]["youngs_modulus"] = 5e5
    case["solver"] = {"type": "implicit"}
    case["implicit"] = {"load_steps": load_steps}
    case["time"] = {"end_time": 1.0}
    case["output"] = {"interval": 0.5}
    return case


def test_a_completed_run_writes_its_steps_and_the_particles(tmp_path, run_case):
    done = run_case(column(), tmp_path)
    assert done.returncode == 0, done.stderr
    out = tmp_path / "out"
    run = json.loads((out / "run.json").read_text())
    assert run["status"] == "completed"
    assert run["provenance"]["solver"] == "implicit"
    summary = run["summary"]
    assert summary["n_steps"] == 4 and summary["n_attempts"] == 4
    assert summary["final_time_s"] == 1.0
    steps = run["load_steps"]
    assert [s["time"] for s in steps] == [0.25, 0.5, 0.75, 1.0]
    # A linear problem: one correction of each step leaves round-off and ends it.
    assert all(s["converged"] and s["residuals"][1] < 1e-10 for s in steps)
    assert all(len(s["residuals"]) == 2 for s in steps)
    assert summary["n_iterations"] == 4
    with open(out / "timeseries.csv") as f:
        rows = list(csv.DictReader(f))
    assert [float(r["time"]) for r in rows] == [0.25, 0.5, 0.75, 1.0]
    assert all(int(r["attempts"]) == 1 for r in rows)
    with h5py.File(out / "particles.h5", "r") as h5:
        # t = 0, the output at 0.5 s (step 2) and the last step (4)
        assert sorted(k for k in h5.keys() if k.startswith("step_")) == [
            "step_00000000",
            "step_00000002",
            "step_00000004",
        ]
    # The top row settles as the closed form says at its height, on average (to the small
    # strains' 1e-3; the points next to the detected top's corners differ by 0.2 %).
    with open(out / "final_particles.csv") as f:
        particles = list(csv.DictReader(f))
    top = max(float(p["y"]) - float(p["uy"]) for p in particles)
    exact = (SURCHARGE * top + WEIGHT * (HEIGHT * top - 0.5 * top * top)) / MODULUS
    row = [p for p in particles if math.isclose(float(p["y"]) - float(p["uy"]), top)]
    assert len(row) == 8
    settlement = -sum(float(p["uy"]) for p in row) / len(row)
    assert abs(settlement / exact - 1.0) < 1e-3


def test_gravity_loading_settles_the_column_before_time_zero(tmp_path, run_case):
    """initial_stress "gravity": load steps under the weight alone before t = 0, written to
    run.json; the displacements are measured from there, so the top row settles by the
    surcharge's q Y / M alone. A settling that cannot converge stops the run (exit 3), named.
    """
    case = column()
    case["initial_stress"] = {"method": "gravity"}
    done = run_case(case, tmp_path / "settled")
    assert done.returncode == 0, done.stderr
    out = tmp_path / "settled" / "out"
    run = json.loads((out / "run.json").read_text())
    settling = run["initial_stress_load_steps"]
    assert settling and all(s["converged"] for s in settling)
    assert run["summary"]["n_initial_stress_steps"] == len(settling)
    assert [s["time"] for s in run["load_steps"]] == [0.25, 0.5, 0.75, 1.0]
    with open(out / "final_particles.csv") as f:
        particles = list(csv.DictReader(f))
    top = max(float(p["y"]) - float(p["uy"]) for p in particles)
    row = [p for p in particles if float(p["y"]) - float(p["uy"]) > top - 0.01]
    assert len(row) == 8
    settlement = -sum(float(p["uy"]) for p in row) / len(row)
    assert settlement == pytest.approx(SURCHARGE * top / MODULUS, rel=1e-3)

    weak = column()
    weak["initial_stress"] = {"method": "gravity"}
    weak["materials"][0].update({"model": "tresca", "cohesion": 1.0})
    weak["boundary_conditions"] = [{"where": "bottom", "fix": "xy"}]
    weak["implicit"].update({"max_cuts": 1, "max_iterations": 8})
    done = run_case(weak, tmp_path / "weak")
    assert done.returncode == 3, done.stderr
    run = json.loads((tmp_path / "weak" / "out" / "run.json").read_text())
    assert run["status"] == "failed"
    assert run["error"].startswith("gravity loading")
    assert run["load_steps"] == []


def pushed_column(method):
    """The column without weight or surcharge, its detected top pushed down 4 mm (a ramp) by
    `method`."""
    case = column()
    case["materials"][0]["unit_weight"] = 0.0
    case["loads"] = []
    case["constraints"] = [
        {
            "apply_on": "detected_boundary",
            "faces": "top",
            "normal_displacement": -0.004,
            "time_function": {"type": "ramp", "ramp_time": 1.0},
            "method": method,
        }
    ]
    return case


def test_a_constraint_writes_its_force_and_gap_per_load_step(tmp_path, run_case):
    # By Nitsche's method the force on the body is -M ln(H / (H - 4 mm)) x 1 m at the end
    # (uniaxial strain, increments on the current height) and a quarter of the push's at the
    # first step.
    done = run_case(pushed_column("nitsche"), tmp_path)
    assert done.returncode == 0, done.stderr
    with open(tmp_path / "out" / "timeseries.csv") as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == 4
    for row in rows:
        push = 0.004 * float(row["time"])
        exact = -MODULUS * math.log(HEIGHT / (HEIGHT - push))
        assert float(row["constraint_0_fy"]) == pytest.approx(exact, rel=1e-3)
        assert abs(float(row["constraint_0_fx"])) < 1e-6
        assert 0.0 <= float(row["constraint_0_gap"]) < 1e-4 * push


def test_a_moving_support_writes_its_reaction_per_load_step(tmp_path, run_case):
    """The weightless column pushed down by its top as a moving support (the grid's top edge,
    the column's top), 1 mm per step. On the UL-FEM the top nodes are the body's top: the force
    on the body is -M ln(H / (H - push)) x 1 m at every step (1e-3), as by Nitsche's method. On
    the MPM the held nodes stay on the grid's edge while the body's top moves below it: the
    first step is the small-strain -M push / H exactly, the later ones are the grid's.
    """
    case = pushed_column("nitsche")
    case.pop("constraints")
    case["grid"]["n_cells"][1] = round(HEIGHT / case["grid"]["cell_size"])
    case["boundary_conditions"].append(
        {
            "where": "top",
            "fix": "y",
            "velocity": [0.0, -0.004],
            "time_function": {"type": "constant"},
        }
    )
    k = len(case["boundary_conditions"]) - 1
    rows = {}
    for solver in ("mpm", "ulfem"):
        done = run_case(case, tmp_path / solver, "--solver", solver)
        assert done.returncode == 0, done.stderr
        with open(tmp_path / solver / "out" / "timeseries.csv") as f:
            rows[solver] = list(csv.DictReader(f))
        assert len(rows[solver]) == 4
        assert all(float(r[f"reaction_{k}_fx"]) == 0.0 for r in rows[solver])
    strain = 0.0
    for n, row in enumerate(rows["ulfem"]):
        # Each step's strain is its push over the height it starts from, so the reaction is
        # M sum 1 mm / (H - n mm) to round-off, which is M ln(H / (H - push)) to 1e-3.
        strain += 0.001 / (HEIGHT - 0.001 * n)
        push = 0.004 * float(row["time"])
        reaction = float(row[f"reaction_{k}_fy"])
        assert reaction == pytest.approx(-MODULUS * strain, rel=1e-9)
        assert reaction == pytest.approx(
            -MODULUS * math.log(HEIGHT / (HEIGHT - push)), rel=1e-3
        )
    first = float(rows["mpm"][0][f"reaction_{k}_fy"])
    assert first == pytest.approx(-MODULUS * 0.001 / HEIGHT, rel=1e-12)


def test_a_step_that_cannot_converge_stops_the_run_with_the_outputs_kept(
    tmp_path, run_case
):
    case = column(load_steps=2)
    case["materials"][0] = {
        "name": "soil",
        "model": "tresca",
        "youngs_modulus": 5e5,
        "poisson_ratio": 0.25,
        "unit_weight": WEIGHT,
        "cohesion": 1.0,
    }
    # Without its side walls a column of 1 kPa clay stands up to 2 kPa of vertical stress, and
    # its weight alone asks for 72 kPa at the base: the first step finds no equilibrium.
    case["boundary_conditions"] = [{"where": "bottom", "fix": "xy"}]
    case["implicit"].update({"max_cuts": 2, "max_iterations": 8})
    done = run_case(case, tmp_path)
    assert done.returncode == 3, done.stderr
    out = tmp_path / "out"
    run = json.loads((out / "run.json").read_text())
    assert run["status"] == "failed"
    assert "did not converge" in run["error"]
    assert "load step 1 from t = 0 s to " in run["error"]
    assert "gravity factor" in run["error"] and "relative residuals" in run["error"]
    assert [s["converged"] for s in run["load_steps"]] == [False] * 3
    assert run["summary"]["n_steps"] == 0
    with h5py.File(out / "particles.h5", "r") as h5:
        assert "step_00000000" in h5  # the state at t = 0
    assert (
        out / "timeseries.csv"
    ).read_text() == "time,dt,iterations,residual,attempts\n"


def expect_refused(cases, make, tmp_path, run_case):
    """Each of `cases` ({JSON path: change of the case `make()` gives}) exits 2 naming its path,
    and creates no output folder."""
    for path, change in cases.items():
        case = make()
        change(case)
        folder = tmp_path / path.strip("/").replace("/", "_")
        done = run_case(case, folder)
        assert done.returncode == 2, (path, done.stderr)
        assert f"case.json: {path}" in done.stderr, (path, done.stderr)
        assert not (folder / "out").exists()


def test_what_the_implicit_solver_cannot_honour_is_refused(tmp_path, run_case):
    cases = {
        "/solver/damping": lambda c: c["solver"].update({"damping": 0.1}),
        "/solver/xpic_order": lambda c: c["solver"].update({"xpic_order": 1}),
        "/time/cfl": lambda c: c["time"].update({"cfl": 0.5}),
        "/implicit": lambda c: c["solver"].update({"type": "explicit"}),
        "/implicit/load_steps": lambda c: c["implicit"].update({"load_steps": 0}),
    }
    expect_refused(cases, column, tmp_path, run_case)


def test_the_ulfem_runs_the_implicit_case_on_its_mesh(tmp_path, run_case):
    """`--solver ulfem` takes the same load steps on the UL-FEM's mesh: the top nodes settle as
    the closed form says (bilinear elements are exact at the nodes of the column), and it takes
    the grid-top load too, with the same answer."""
    settlements = []
    for apply_on in ("detected_boundary", "grid_top_nodes"):
        case = column()
        case["loads"][0]["apply_on"] = apply_on
        folder = tmp_path / apply_on
        done = run_case(case, folder, "--solver", "ulfem")
        assert done.returncode == 0, done.stderr
        run = json.loads((folder / "out" / "run.json").read_text())
        assert run["summary"]["solver"] == "ulfem_implicit"
        assert run["summary"]["n_steps"] == 4 and run["summary"]["n_iterations"] == 4
        assert [o["boundary"] for o in run["outputs"]] == [
            "boundary_00000000.csv",
            "boundary_00000002.csv",
            "boundary_00000004.csv",
        ]
        with open(folder / "out" / "boundary_00000004.csv") as f:
            top = max(float(r["y"]) for r in csv.DictReader(f))
        settlements.append(HEIGHT - top)
    exact = (SURCHARGE * HEIGHT + WEIGHT * HEIGHT**2 / 2) / MODULUS
    assert settlements[0] == pytest.approx(exact, rel=1e-3)
    assert settlements[1] == pytest.approx(settlements[0], rel=1e-12)


def test_what_the_implicit_boundary_method_cannot_honour_is_refused(tmp_path, run_case):
    # The IBM changes the stiffness matrix, which the explicit step does not have; its band's
    # stiffness is the material's, so a penalty is not read, and the band only by the IBM.
    def constraint(c):
        return c["constraints"][0]

    cases = {
        "/constraints/0/method": lambda c: c["solver"].update({"type": "explicit"})
        or c.pop("implicit"),
        "/constraints/0/penalty_factor": lambda c: constraint(c).update(
            {"penalty_factor": 16.0}
        ),
        "/constraints/0/penalty": lambda c: constraint(c).update({"penalty": 1e7}),
        "/constraints/0/band_factor": lambda c: constraint(c).update(
            {"band_factor": 0.0}
        ),
    }
    expect_refused(cases, lambda: pushed_column("ibm"), tmp_path, run_case)
    case = pushed_column("nitsche")
    constraint(case)["band_factor"] = 1e-3
    done = run_case(case, tmp_path / "nitsche")
    assert done.returncode == 2 and "/constraints/0/band_factor" in done.stderr


def test_ties_act_with_constraints_only_in_the_implicit_solver(tmp_path, run_case):
    # The implicit constraints act through each node's map of unknowns, ties included; the
    # explicit ones put their forces on the nodes with mass and refuse ties.
    case = pushed_column("nitsche")
    case["solver"]["outer_node_fraction"] = 0.1
    done = run_case(case, tmp_path / "implicit")
    assert done.returncode == 0, done.stderr
    case["solver"] = {"type": "explicit", "outer_node_fraction": 0.1}
    del case["implicit"]
    done = run_case(case, tmp_path / "explicit")
    assert done.returncode == 2 and "/solver/outer_node_fraction" in done.stderr
