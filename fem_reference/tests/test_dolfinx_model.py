"""Verification of the dolfinx reference model (fem_reference/dolfinx_model).

Each test asserts a physical or mathematical fact with a stated tolerance and prints the
measured figures (run pytest -s to see them)."""
import json
import math
import os

import numpy as np
import pytest

from fem_reference.crosscheck import PRANDTL_DOLFINX_RUN
from fem_reference.dolfinx_model import (
    CaseError,
    Model,
    read_case,
    run_explicit,
    run_static,
    write_boundary_csv,
)
from fem_reference.dolfinx_model.case import Cohesion, Material
from fem_reference.dolfinx_model.material import ElasticPlasticModel

DATA = os.path.join(os.path.dirname(__file__), "data")


def data(name):
    return os.path.join(DATA, name)


def constrained_modulus(e, nu):
    return e * (1 - nu) / ((1 + nu) * (1 - 2 * nu))


# ------------------------------------------------------------------------- 1. oedometer
@pytest.mark.parametrize("quads", [False, True], ids=["P2-triangles", "Q2-quads"])
def test_oedometric_column_self_weight(quads):
    """Top settlement = gamma H^2 / (2 M) within 0.5 %; szz = sxx = nu/(1-nu) syy."""
    case = read_case(data("oedometer_column.json"))
    model = Model(case, degree=2, quads=quads)
    model.add_probe("top", (0.5, 5.0))
    result = run_static(case, model=model, initial_stress_method="zero")
    exact = 20.0 * 5.0**2 / (2 * constrained_modulus(1e4, 0.15))
    settlement = -model.probe_displacement("top")[1]
    print(
        f"\noedometer ({'quads' if quads else 'triangles'}): settlement {settlement:.6e} m, "
        f"exact {exact:.6e} m, "
        f"runtime {result.runtime:.2f} s"
    )
    assert abs(settlement - exact) <= 0.005 * exact
    k0 = 0.15 / 0.85
    s = model.stress
    assert np.allclose(s[:, 0], k0 * s[:, 1], rtol=1e-6, atol=1e-6)
    assert np.allclose(s[:, 3], k0 * s[:, 1], rtol=1e-6, atol=1e-6)


def test_initial_stress_procedures_agree_on_level_ground():
    """K0 with K0 = nu/(1-nu) is the oedometric self-weight state: already in equilibrium
    (no displacement, 1e-9 m) and equal to the stress of the gravity procedure (1e-6 kPa),
    whose displacements are reset to zero."""
    case = read_case(data("oedometer_column.json"))
    k0_model = Model(case)
    run_static(case, model=k0_model, initial_stress_method="k0")
    assert np.abs(k0_model.u.x.array).max() < 1e-9
    grav_model = Model(case)
    run_static(case, model=grav_model, initial_stress_method="gravity")
    assert np.abs(grav_model.u.x.array).max() == 0.0
    assert np.allclose(k0_model.stress, grav_model.stress, atol=1e-6)


def test_updated_lagrangian_column_large_strain_solution():
    """Updated Lagrangian (Jaumann, hypoelastic, weight conserved): the top settlement tends to
    the large-strain 1D solution H - (M/gamma)(1 - exp(-gamma H / M)) (Cauchy stress = M ln
    stretch); 20 gravity increments are within 0.05 % of it, while the small-strain value is
    0.32 % away."""
    case = read_case(data("oedometer_column.json"))
    gamma, height = 20.0, 5.0
    m_mod = constrained_modulus(1e4, 0.15)
    large = height - (m_mod / gamma) * (1 - math.exp(-gamma * height / m_mod))
    small = gamma * height**2 / (2 * m_mod)
    model = Model(case, updated_lagrangian=True)
    model.add_probe("top", (0.5, 5.0))
    run_static(case, model=model, gravity_steps=20)
    settlement = -model.probe_displacement("top")[1]
    print(
        f"\nUL column: settlement {settlement:.6e} m, large-strain {large:.6e} m, "
        f"small-strain {small:.6e} m"
    )
    assert abs(settlement - large) <= 5e-4 * large
    assert abs(small - large) > 6 * 5e-4 * large


def test_uniform_surface_load_is_oedometric():
    """q over the whole top of the weightless bearing block: settlement q H / M within 0.5 %
    (checks the pressure load path: facets, normals, resultant)."""
    raw = json.load(open(data("bearing_block_elastic.json")))
    raw["gravity"] = {"g": 0}  # weightless; unit_weight stays (density = 20 / 9.81)
    raw["loads"][0]["x_range"] = [0, 15]
    raw["initial_stress"] = {
        "method": "zero"
    }  # kinetic_energy_ratio: gravity method only
    from fem_reference.dolfinx_model import case_from_dict

    case = case_from_dict(raw, "uniform")
    result = run_static(case, steps=1, element_size=1.0)
    exact = 50.0 * 5.0 / constrained_modulus(1e4, 0.15)
    print(
        f"\nuniform load: settlement {result.curve[-1][1]:.6e} m, exact {exact:.6e} m"
    )
    assert abs(result.curve[-1][1] - exact) <= 0.005 * exact


# ------------------------------------------------------------------------- 2. bearing, elastic
def test_bearing_block_elastic_settlement():
    """Settlement at the strip centre due to q_v (gravity procedure first): P2 triangles of
    0.5 m and 0.25 m and Q2 quadrilaterals of 0.5 m agree within 1 %; the external vertical
    force equals q B + weight to 1e-9 (relative). Every run gives 2.0634e-2 m within 0.1 %: the
    value the C++ UL-FEM test (tests/cpp/fem/test_ulfem_physics.cpp,
    ElasticBearingBlockSettlement) compares with (2 %)."""
    case = read_case(data("bearing_block_elastic.json"))
    values = []
    for h, quads in ((0.5, True), (0.5, False), (0.25, False)):
        result = run_static(case, steps=1, element_size=h, quads=quads)
        assert result.initial_stress == "gravity"
        assert result.converged_to_full_load
        values.append(result.curve[-1][1])
        print(
            f"\nbearing elastic h={h} {'Q2' if quads else 'P2'}: settlement {values[-1]:.6e} m, "
            f"cells {result.model.n_cells}, runtime {result.runtime:.2f} s"
        )
    assert max(values) - min(values) <= 0.01 * values[-1]
    ulfem_test_value = 2.0634e-2  # m, kDolfinxSettlement in test_ulfem_physics.cpp
    assert all(abs(v - ulfem_test_value) <= 1e-3 * ulfem_test_value for v in values)
    fy = result.model.external_force().reshape(-1, 2)[:, 1].sum()
    assert abs(fy + (50.0 * 5.0 + 20.0 * 75.0)) <= 1e-9 * (50.0 * 5.0 + 20.0 * 75.0)


# ------------------------------------------------------------------------- 3. Prandtl
def test_bearing_block_tresca_collapse_load():
    """Weightless (g = 0) Tresca c = 20 kPa: load-controlled Newton with step halving; the last
    converged pressure is within 3 % of Prandtl's (2 + pi) c, and the last converged increment
    has a secant stiffness below 5 % of the initial elastic one (a plateau)."""
    case = read_case(data("bearing_block_tresca.json"))
    result = run_static(case, **PRANDTL_DOLFINX_RUN)
    prandtl = (2 + math.pi) * 20.0
    collapse = result.collapse_load
    curve = np.array(result.curve)
    print(
        f"\nTresca collapse load {collapse:.2f} kPa, Prandtl {prandtl:.2f} kPa "
        f"({100 * (collapse / prandtl - 1):+.2f} %), settlement at collapse "
        f"{curve[-1, 1]:.4f} m, Newton iterations {result.newton_iterations}, cells "
        f"{result.model.n_cells}, runtime {result.runtime:.1f} s"
    )
    assert abs(collapse - prandtl) <= 0.03 * prandtl
    initial_stiffness = curve[1, 0] / curve[1, 1]  # kPa/m, first (elastic) increment
    last_stiffness = (curve[-1, 0] - curve[-2, 0]) / (curve[-1, 1] - curve[-2, 1])
    print(
        f"last-increment stiffness / initial: {last_stiffness / initial_stiffness:.4f}"
    )
    assert last_stiffness < 0.05 * initial_stiffness


def test_strength_reduction_of_a_pressed_block():
    """A weightless Tresca block (c = 20 kPa) 1 m high, by symmetry 2 m wide, on a smooth
    base, free on its right, under q = 30 kPa: uniform stress, so its strength reduction fails
    at F = 2 c / q = 4/3; increments of 0.03 halved until below min_step = 1e-3 bracket it
    within 2 min_step (the last increment tried before the stop), and the bracket holds 4/3 to
    1e-9. The same case as the MPM's (test_implicit_solver.cpp)."""
    from fem_reference.dolfinx_model import case_from_dict
    from fem_reference.dolfinx_model.analysis import run_strength_reduction

    raw = {
        "grid": {"origin": [0, 0], "cell_size": 0.25, "n_cells": [8, 6]},
        "materials": [
            {
                "name": "clay",
                "model": "tresca",
                "youngs_modulus": 1e4,
                "poisson_ratio": 0.3,
                "unit_weight": 18.0,
                "cohesion": 20.0,
            }
        ],
        "bodies": [
            {"name": "block", "material": "clay", "rectangle": [[0, 0], [1, 1]]}
        ],
        "gravity": {"g": 0.0},
        "boundary_conditions": [
            {"where": "bottom", "fix": "y"},
            {"where": "left", "fix": "x"},
        ],
        "loads": [
            {
                "type": "vertical_pressure",
                "pressure": 30.0,
                "x_range": [0, 1],
                "apply_on": "detected_boundary",
            }
        ],
        "solver": {"type": "implicit"},
        "implicit": {
            "load_steps": 40,
            "strength_reduction": {"start_time": 1.0, "final_factor": 1.6},
        },
        "time": {"end_time": 2.0},
    }
    case = case_from_dict(raw, "block")
    result = run_strength_reduction(case, 1.6, steps=20, load_steps=2)
    print(
        f"\nblock: factor of safety in [{result.last_converged_factor:.5f}, "
        f"{result.failed_factor:.5f}], closed form {4 / 3:.5f}"
    )
    assert result.failed_factor is not None
    assert result.failed_factor - result.last_converged_factor < 2e-3
    assert result.last_converged_factor <= 4 / 3 + 1e-9
    assert result.failed_factor >= 4 / 3 - 1e-9


# ------------------------------------------------------------------------- 4. slope
def test_slope_elastic_crest_displacement_mesh_converged():
    """Geometry of cases/thesis55_slope_dynamic_zero_start.json (toe x = 10.125, crest x = 14.125, 4 m high, 6 m base,
    26 m wide), elastic E = 1000 kPa, nu = 0.33: gravity switched on (zero initial stress,
    displacements kept); the crest displacement of the 0.5 m and 0.25 m meshes agree within
    2 % (vector norm)."""
    case = read_case(data("slope_elastic.json"))
    crest = []
    for h in (0.5, 0.25):
        model = Model(case, element_size=h)
        model.add_probe("crest", (14.125, 10.0))
        assert model.probes["crest"][2] < 1e-12  # the crest is a mesh node
        result = run_static(case, model=model)
        crest.append(model.probe_displacement("crest"))
        print(
            f"\nslope h={h}: crest (ux, uy) = ({crest[-1][0]:.5e}, {crest[-1][1]:.5e}) m, "
            f"cells {model.n_cells}, runtime {result.runtime:.2f} s"
        )
    diff = np.linalg.norm(crest[0] - crest[1])
    assert diff <= 0.02 * np.linalg.norm(crest[1])


# ------------------------------------------------------------------------- explicit dynamics
def test_explicit_column_sudden_gravity():
    """Explicit P1 lumped mass, column with gravity switched on at t = 0: undamped, the top
    reaches 2 x the static settlement (the dynamic amplification of a step load) within 3 %;
    with local damping 0.7 it settles to the static value within 0.5 %."""
    case = read_case(data("oedometer_column.json"))
    static = 20.0 * 5.0**2 / (2 * constrained_modulus(1e4, 0.15))
    model = Model(case, degree=1, element_size=0.25)
    model.add_probe("top", (0.5, 5.0))
    result = run_explicit(case, end_time=0.3, model=model, series_interval=1e-12)
    peak = -min(uy for _, _, uy in result.probe_history["top"])
    print(
        f"\nexplicit undamped: peak/static {peak / static:.4f}, dt {result.dt:.3e} s, "
        f"{result.n_steps} steps, runtime {result.runtime:.2f} s"
    )
    assert abs(peak - 2 * static) <= 0.03 * 2 * static
    case.damping = 0.7
    model = Model(case, degree=1, element_size=0.25)
    model.add_probe("top", (0.5, 5.0))
    result = run_explicit(case, end_time=3.0, model=model)
    final = -model.probe_displacement("top")[1]
    print(
        f"explicit damped: final/static {final / static:.5f}, runtime {result.runtime:.2f} s"
    )
    assert abs(final - static) <= 0.005 * static


# ------------------------------------------------------------------------- outputs, input
def test_boundary_csv_order(tmp_path):
    """Undeformed slope outline: one loop, counter-clockwise, area = polygon area (1e-9),
    first point the lowest-then-leftmost, no repeated closing point, every polygon vertex on it.
    """
    case = read_case(data("slope_elastic.json"))
    model = Model(case, element_size=1.0)
    loops = model.boundary_loops()
    assert len(loops) == 1
    pts = loops[0]
    area = 0.5 * np.sum(
        pts[:, 0] * np.roll(pts[:, 1], -1) - np.roll(pts[:, 0], -1) * pts[:, 1]
    )
    polygon = np.array(case.bodies[0].polygon)
    exact = 0.5 * np.sum(
        polygon[:, 0] * np.roll(polygon[:, 1], -1)
        - np.roll(polygon[:, 0], -1) * polygon[:, 1]
    )
    assert area > 0 and abs(area - exact) <= 1e-9 * exact
    assert np.allclose(pts[0], [0.0, 0.0], atol=1e-12)
    assert not np.allclose(pts[0], pts[-1])
    for vertex in polygon:
        assert np.min(np.linalg.norm(pts - vertex, axis=1)) < 1e-12
    path = tmp_path / "boundary.csv"
    write_boundary_csv(loops, path)
    lines = path.read_text().splitlines()
    assert lines[0] == "loop,x,y" and len(lines) == len(pts) + 1


def test_case_reader_rejects_unknown_key(tmp_path):
    """Same contract as the C++ reader: file + JSON pointer in the message."""
    raw = json.load(open(data("oedometer_column.json")))
    raw["materials"][0]["colour"] = "brown"
    path = tmp_path / "bad.json"
    path.write_text(json.dumps(raw))
    with pytest.raises(CaseError, match=r"bad\.json: /materials/0/colour: unknown key"):
        read_case(path)


# ------------------------------------------------------------------------- constitutive
def test_tresca_return_mapping_properties():
    """Random plane-strain increments from zero stress with softening 20 -> 10 kPa:
    f <= 1e-9 kPa after the return (= 0 where plastic); the plastic strain increment is traceless
    (Tresca is isochoric, 1e-12); the dissipation sigma : eps_p = c(kappa) kappa (1e-8) at main
    plane and edge returns alike; the FD tangent equals D for elastic points."""
    mat = Material("c", "tresca", 1e4, 0.3, 20.0, Cohesion([0.0, 0.05], [20.0, 10.0]))
    model = ElasticPlasticModel(mat)
    rng = np.random.default_rng(7)
    n = 2000
    dstrain = rng.normal(size=(n, 3)) * 3e-3
    stress, kappa, tangent = model.update_with_tangent(
        np.zeros((n, 4)), np.zeros(n), dstrain
    )
    p = 0.5 * (stress[:, 0] + stress[:, 1])
    r = np.hypot(0.5 * (stress[:, 0] - stress[:, 1]), stress[:, 2])
    tri = np.stack([p + r, p - r, stress[:, 3]], axis=1)
    f = 0.5 * (tri.max(axis=1) - tri.min(axis=1)) - mat.cohesion.value(kappa)
    assert f.max() <= 1e-9
    assert (kappa > 0).sum() > n // 4 and kappa.min() >= 0.0
    # elastic strain from the stress, plastic = total - elastic (3D, ezz total = 0)
    lam, mu = model.lam, model.mu
    e_mod = mu * (3 * lam + 2 * mu) / (lam + mu)
    nu = lam / (2 * (lam + mu))
    trace_s = stress[:, 0] + stress[:, 1] + stress[:, 3]
    elastic = [((1 + nu) * stress[:, k] - nu * trace_s) / e_mod for k in (0, 1, 3)]
    plastic_trace = dstrain[:, 0] + dstrain[:, 1] - sum(elastic)
    assert np.abs(plastic_trace).max() <= 1e-12
    # consistency on the yield surface; kappa is the plastic shear strain of the active planes,
    # so for associated Tresca the plastic dissipation sigma : eps_p equals c(kappa) kappa
    assert np.abs(f[kappa > 0]).max() <= 1e-9
    gxy_el = stress[:, 2] / mu
    ep = np.stack(
        [
            dstrain[:, 0] - elastic[0],
            dstrain[:, 1] - elastic[1],
            -elastic[2],
            dstrain[:, 2] - gxy_el,
        ],
        axis=1,
    )  # (xx, yy, zz, engineering xy)
    dissipation = (
        stress[:, 0] * ep[:, 0]
        + stress[:, 1] * ep[:, 1]
        + stress[:, 3] * ep[:, 2]
        + stress[:, 2] * ep[:, 3]
    )
    assert np.allclose(
        dissipation, mat.cohesion.value(kappa) * kappa, rtol=1e-8, atol=1e-12
    )
    ordered = np.sort(tri, axis=1)
    gap = np.minimum(ordered[:, 2] - ordered[:, 1], ordered[:, 1] - ordered[:, 0])
    plastic = kappa > 0
    assert (plastic & (gap > 1e-6)).sum() > n // 10  # main-plane returns were checked
    assert (plastic & (gap < 1e-9)).sum() > n // 100  # and edge returns
    elastic_points = kappa == 0
    assert np.allclose(tangent[elastic_points & (f < -1.0)], model.elastic_matrix())


def _principal(stress):
    p = 0.5 * (stress[:, 0] + stress[:, 1])
    r = np.hypot(0.5 * (stress[:, 0] - stress[:, 1]), stress[:, 2])
    return np.stack([p + r, p - r, stress[:, 3]], axis=1)


@pytest.mark.parametrize(
    "phi, psi, cutoff", [(30.0, 30.0, 1e9), (30.0, 5.0, None), (20.0, 0.0, 5.0)]
)
def test_mohr_coulomb_return_mapping(phi, psi, cutoff):
    """Random increments from a compressive state, softening 20 -> 10 kPa: every returned
    stress is admissible (shear and tension planes, 1e-9 kPa), the tension cut-off is reached by
    some points when it is below the apex, and for associated flow (psi = phi) the dissipation
    sigma : eps_p = c(kappa) cos(phi) kappa (1e-8)."""
    mat = Material(
        "m",
        "mohr_coulomb",
        1e4,
        0.3,
        20.0,
        Cohesion([0.0, 0.05], [20.0, 10.0]),
        phi,
        psi,
        None,
    )
    mat.tension_cutoff = (
        cutoff if cutoff is not None else 20.0 / math.tan(math.radians(phi))
    )
    model = ElasticPlasticModel(mat)
    rng = np.random.default_rng(3)
    n = 3000
    start = np.tile([-50.0, -80.0, 0.0, -60.0], (n, 1))
    dstrain = rng.normal(size=(n, 3)) * 3e-3
    stress, kappa, _ = model.update_with_tangent(start, np.zeros(n), dstrain)
    tri = _principal(stress)
    assert model._violation(tri, kappa).max() <= 1e-9
    assert (kappa > 0).sum() > n // 20
    limit = model.tension_limit(mat.cohesion.value(kappa))
    if cutoff is not None and cutoff < 20.0 / math.tan(math.radians(phi)):
        assert np.sum(np.abs(tri.max(axis=1) - limit) < 1e-9) > n // 100
    if psi == phi:
        lam, mu = model.lam, model.mu
        e_mod = mu * (3 * lam + 2 * mu) / (lam + mu)
        nu = lam / (2 * (lam + mu))
        ds = stress - start
        trace = ds[:, 0] + ds[:, 1] + ds[:, 3]
        el = [((1 + nu) * ds[:, k] - nu * trace) / e_mod for k in (0, 1, 3)]
        ep = [
            dstrain[:, 0] - el[0],
            dstrain[:, 1] - el[1],
            -el[2],
            dstrain[:, 2] - ds[:, 2] / mu,
        ]
        dissipation = (
            stress[:, 0] * ep[0]
            + stress[:, 1] * ep[1]
            + stress[:, 3] * ep[2]
            + stress[:, 2] * ep[3]
        )
        expected = mat.cohesion.value(kappa) * math.cos(math.radians(phi)) * kappa
        assert np.allclose(dissipation, expected, rtol=1e-8, atol=1e-10)


def test_cli_outputs_and_bad_input(tmp_path):
    """The CLI writes the boundary, load-settlement, fields and summary files. Run on
    bearing_block_elastic.json with its load moved to the detected boundary (and a detection
    block), its settlement is the API's for the file as it is (1e-9 relative: on the flat top
    both loads are the same), and summary.json lists the detection block as ignored; a case with
    an unknown key exits with code 2 and writes nothing."""
    import csv
    import subprocess
    import sys

    root = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))
    out = tmp_path / "run"
    detected = json.load(open(data("bearing_block_elastic.json")))
    detected["loads"][0].update(apply_on="detected_boundary", curve="cubic")
    detected["detection"] = {"method": "improved", "every_steps": 2}
    detected_path = tmp_path / "detected.json"
    detected_path.write_text(json.dumps(detected))
    cmd = [
        sys.executable,
        "-m",
        "fem_reference.dolfinx_model",
        str(detected_path),
        "--out",
        str(out),
        "--steps",
        "2",
    ]
    done = subprocess.run(cmd, cwd=root, capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    for name in (
        "boundary.csv",
        "load_settlement.csv",
        "fields.xdmf",
        "fields.h5",
        "summary.json",
    ):
        assert (out / name).exists()
    rows = list(csv.DictReader(open(out / "load_settlement.csv")))
    ignored = json.load(open(out / "summary.json"))["ignored"]
    assert any(item.startswith("/detection: ") for item in ignored)
    assert any(item.startswith("/loads/0/curve: ") for item in ignored)
    assert [float(r["load"]) for r in rows] == [0.0, 25.0, 50.0]
    api = run_static(data("bearing_block_elastic.json"), steps=2).curve[-1][1]
    assert abs(float(rows[-1]["settlement"]) - api) <= 1e-9 * api
    raw = json.load(open(data("bearing_block_elastic.json")))
    raw["loads"][0]["colour"] = "red"
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps(raw))
    cmd = [
        sys.executable,
        "-m",
        "fem_reference.dolfinx_model",
        str(bad),
        "--out",
        str(tmp_path / "no"),
    ]
    done = subprocess.run(cmd, cwd=root, capture_output=True, text=True)
    assert done.returncode == 2
    assert "bad.json: /loads/0/colour: unknown key" in done.stderr
    assert not (tmp_path / "no").exists()


# ------------------------------------------------------------------------- displacement control
def driven_specimen(material: dict, time_function: dict, velocity=0.05, cell=0.25):
    """A 1 x 2 m specimen between smooth platens (bottom: y fixed, the bottom-left corner also
    x), the top platen driven down at `velocity` (m/s) times `time_function`; weightless.
    """
    return {
        "title": "driven specimen",
        "grid": {"origin": [0, 0], "cell_size": cell, "n_cells": [4, 8]},
        "materials": [dict(name="m", unit_weight=20.0, **material)],
        "bodies": [{"name": "b", "material": "m", "rectangle": [[0, 0], [1, 2]]}],
        "gravity": {"g": 0.0},
        "node_sets": [{"name": "corner", "box": [[0, 0], [0, 0]]}],
        "boundary_conditions": [
            {"where": "bottom", "fix": "y"},
            {"where": "corner", "fix": "x"},
            {
                "where": "top",
                "fix": "y",
                "velocity": [0.0, -velocity],
                "time_function": time_function,
            },
        ],
        "time": {"end_time": 1.0},
    }


def test_driven_elastic_specimen_reaction_is_exact():
    """A platen moved by its velocity times the integral of a smooth ramp: its displacement is
    that integral (the quadrature of the ramp, 1e-12 m) and the reaction the plane-strain
    uniaxial one, E / (1 - nu^2) W d / H, at every increment (1e-9 relative: a homogeneous
    field is exact in P2); the reactions of the fixed supports balance it (1e-9)."""
    from scipy.integrate import quad

    from fem_reference.dolfinx_model import case_from_dict, run_driven
    from fem_reference.dolfinx_model.case import time_function_factor

    ramp = {"type": "smooth_ramp", "ramp_time": 0.4}
    material = {"model": "linear_elastic", "youngs_modulus": 1e4, "poisson_ratio": 0.3}
    case = case_from_dict(driven_specimen(material, ramp))
    result = run_driven(case, steps=5, degree=2)
    assert result.converged_to_end and len(result.series) == 6
    columns = result.columns
    assert columns == [
        "time",
        "displacement_2_x",
        "displacement_2_y",
        "reaction_2_fx",
        "reaction_2_fy",
    ]
    stiffness = 1e4 / (1 - 0.3**2) * 1.0 / 2.0  # kN/m per m
    worst = 0.0
    for t, ux, uy, fx, fy in result.series:
        exact_u = -0.05 * quad(lambda s: time_function_factor(ramp, s), 0.0, t)[0]
        assert abs(uy - exact_u) <= 1e-12 and ux == 0.0
        exact_f = stiffness * uy
        if t > 0:
            worst = max(worst, abs(fy - exact_f) / abs(exact_f))
        assert abs(fx) <= 1e-9 * stiffness * 0.05
    reactions = result.model.reactions()
    total_y = sum(r[1] for r in reactions)
    print(
        f"\ndriven elastic specimen: worst reaction error {worst:.2e}, sum {total_y:.1e}"
    )
    assert worst <= 1e-9
    assert abs(total_y) <= 1e-9 * abs(reactions[2][1])


KAPPA_HOMOGENEOUS = (
    0.085  # the softening specimen's homogeneous path, checked up to here
)


@pytest.mark.parametrize("softening_length", [None, 0.5], ids=["plain", "regularised"])
def test_driven_softening_specimen_follows_the_law(softening_length):
    """Tresca softening c = 20 -> 10 kPa over a plastic strain of 0.2 (regularised with
    L = 2 h: over 0.4), a homogeneous specimen shortened by d past its peak: kappa =
    eps1_p - eps3_p = 2 |eps_yy^p|, so d / H = 2 c(kappa) / E' + kappa / 2 with
    E' = E / (1 - nu^2), and the force is 2 c(kappa) W. The driven run (to d / H = 0.05,
    kappa = 0.095) gives that force within 1e-5 relative at every increment up to
    kappa = KAPPA_HOMOGENEOUS, through the peak and down the softening branch. Further down,
    the homogeneous path is an unstable equilibrium (softening): the points' kappa part from
    round-off, where depends on the machine's arithmetic (the plain law's last increment may
    already be 1e-5 off), and the specimen localises, as it should; hence the short run.
    """
    from fem_reference.dolfinx_model import case_from_dict, run_driven

    material = {
        "model": "tresca",
        "youngs_modulus": 1e4,
        "poisson_ratio": 0.3,
        "cohesion": {"table": [[0.0, 20.0], [0.2, 10.0]]},
    }
    if softening_length:
        material["softening_length"] = softening_length
    case = case_from_dict(driven_specimen(material, {"type": "constant"}, velocity=0.1))
    result = run_driven(case, steps=8, degree=2)
    assert result.converged_to_end
    e_prime = 1e4 / (1 - 0.3**2)
    span = 0.2 * (softening_length or 0.25) / 0.25  # the law's plastic strain span
    slope = -10.0 / span  # dc / dkappa
    worst, softened = 0.0, 0.0
    for t, _, uy, _, fy in result.series:
        d, force = -uy, -fy
        kappa = max(0.0, (d / 2.0 - 40.0 / e_prime) / (0.5 + 2.0 * slope / e_prime))
        cohesion = max(10.0, 20.0 + slope * kappa)
        exact = 2.0 * cohesion if kappa > 0 else e_prime * d / 2.0
        if t > 0 and kappa <= KAPPA_HOMOGENEOUS:
            worst = max(worst, abs(force - exact) / exact)
        softened = max(softened, 40.0 - force)
    print(
        f"\ndriven softening specimen ({softening_length}): worst force error "
        f"{worst:.2e}, softened by {softened:.2f} kN/m"
    )
    assert worst <= 1e-5
    # down the softening branch: plain by 9.5 kN/m, regularised (half the slope) by 4.7
    assert softened >= (9.0 if softening_length is None else 4.5)


def test_driven_mode_refusals(tmp_path):
    """A moving support is displacement control: load control (run_static, --collapse) and
    the explicit mode refuse it with the boundary condition's JSON path (exit 2)."""
    import subprocess
    import sys

    from fem_reference.dolfinx_model import case_from_dict

    material = {"model": "linear_elastic", "youngs_modulus": 1e4, "poisson_ratio": 0.3}
    raw = driven_specimen(material, {"type": "constant"})
    with pytest.raises(ValueError, match="/boundary_conditions/2/velocity"):
        run_static(case_from_dict(raw))
    path = tmp_path / "driven.json"
    path.write_text(json.dumps(raw))
    root = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))
    for extra in (["--mode", "explicit"], ["--collapse"]):
        done = subprocess.run(
            [sys.executable, "-m", "fem_reference.dolfinx_model", str(path)]
            + ["--out", str(tmp_path / "no")]
            + extra,
            cwd=root,
            capture_output=True,
            text=True,
        )
        assert done.returncode == 2, done.stderr
        assert "driven.json: /boundary_conditions/2/velocity" in done.stderr
        assert not (tmp_path / "no").exists()
