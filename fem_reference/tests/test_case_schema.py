"""The dolfinx model reads the same case files as the C++ codes (README "Case-file reference"):
the full schema is accepted (detection block, detected-boundary loads, solver / time / output
keys), unknown keys are refused with their JSON pointer, and surface loads follow the C++ rule
(vertical_pressure t = (0, -q n_y) on the top faces, follower_pressure t = -p n, traction t),
integrated exactly on the mesh boundary.

Each test states the fact it checks and its tolerance; run pytest -s to see the figures."""
import copy
import glob
import json
import math
import os

import numpy as np
import pytest

from fem_reference.dolfinx_model import (
    CaseError,
    Model,
    case_from_dict,
    read_case,
    run_static,
)

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))
CASES = sorted(glob.glob(os.path.join(ROOT, "cases", "*.json")))
ELASTIC = {
    "name": "soil",
    "model": "linear_elastic",
    "youngs_modulus": 1e4,
    "poisson_ratio": 0.15,
    "unit_weight": 20.0,
}


def shipped(name):
    with open(os.path.join(ROOT, "cases", name)) as f:
        return json.load(f)


def elastic_bearing_block():
    """cases/thesis62_bearing_dynamic_zero_start.json with the linear elastic soil of the reference tests."""
    raw = shipped("thesis62_bearing_dynamic_zero_start.json")
    raw["materials"] = [dict(ELASTIC)]
    return raw


def resultant(model, k):
    """Sum of the nodal forces of load k at full magnitude (kN/m)."""
    return model.load_vector(k, factor=1.0).reshape(-1, 2).sum(axis=0)


# ------------------------------------------------------------------------- parsing
@pytest.mark.parametrize("path", CASES, ids=[os.path.basename(p) for p in CASES])
def test_every_shipped_case_parses(path):
    """Every cases/*.json is read without error (no solve); a detection block and the MPM-only
    integration keys of detected-boundary loads are accepted and listed as ignored."""
    assert CASES, "no case files found"
    if "constraints" in json.loads(open(path).read()):
        # Constraints on a detected boundary are the MPM's: refused with the path.
        with pytest.raises(CaseError, match="/constraints: the dolfinx model"):
            read_case(path)
        return
    case = read_case(path)
    raw = case.raw
    if "detection" in raw:
        assert case.detection == raw["detection"]
        assert any(item.startswith("/detection:") for item in case.ignored)
    for k, load in enumerate(raw.get("loads", [])):
        assert case.loads[k].apply_on == load.get("apply_on", "grid_top_nodes")
        for key in ("curve", "integration", "gauss_points"):
            if key in load:
                assert any(
                    item.startswith(f"/loads/{k}/{key}:") for item in case.ignored
                )


def test_detected_load_keys_and_defaults():
    """Every key of a detected-boundary load is accepted, with the C++ defaults (faces "top" for
    vertical_pressure, "all" otherwise; interval "fixed"; no x_range = the whole boundary).
    """
    raw = elastic_bearing_block()
    full = {
        "apply_on": "detected_boundary",
        "type": "vertical_pressure",
        "pressure": 50.0,
        "x_range": [5.0, 10.0],
        "faces": "upward",
        "curve": "cubic",
        "integration": "thesis",
        "gauss_points": 7,
        "split_at_cell_edges": False,
        "scale_eq_6_15": True,
        "redistribute_lost_load": True,
        "interval": "material",
        "time_function": {"type": "ramp", "ramp_time": 0.5},
    }
    raw["loads"] = [
        full,
        {
            "apply_on": "detected_boundary",
            "type": "follower_pressure",
            "pressure": -5.0,
        },
        {"apply_on": "detected_boundary", "type": "traction", "traction": [1.0, -2.0]},
    ]
    raw["output"]["nodal_loads"] = True
    raw["detection"] = {
        "method": "pfm",
        "every_steps": 4,
        "pfm": {"kernel_factor": 1.5, "gaussian_size": 3},
        "improved": {"radius_factor": 1.2},
    }
    case = case_from_dict(raw, "full.json")
    first, follower, traction = case.loads
    assert (first.faces, first.interval, first.time_function["ramp_time"]) == (
        "upward",
        "material",
        0.5,
    )
    assert (follower.faces, follower.interval, follower.x_range) == (
        "all",
        "fixed",
        None,
    )
    assert traction.traction == (1.0, -2.0) and traction.pressure is None
    assert traction.magnitude == pytest.approx(np.sqrt(5.0), rel=1e-15)
    ignored = "\n".join(case.ignored)
    for key in ("curve", "integration", "gauss_points", "split_at_cell_edges"):
        assert f"/loads/0/{key}:" in ignored
    assert "/output/nodal_loads:" in ignored and "/detection:" in ignored


@pytest.mark.parametrize(
    "edit, message",
    [
        (lambda r: r["loads"][0].update(colour="red"), "/loads/0/colour: unknown key"),
        (lambda r: r["detection"].update(radius=2), "/detection/radius: unknown key"),
        (
            lambda r: r["detection"].update(improved={"radius": 2}),
            "/detection/improved/radius: unknown key",
        ),
        (
            lambda r: r["detection"].update(method="magic"),
            '/detection/method: "magic" is not one of "pfm"',
        ),
        (lambda r: r["output"].update(colour=1), "/output/colour: unknown key"),
        (
            lambda r: r["solver"].update(scheme="rk4"),
            '/solver/scheme: "rk4" is not one of "musl", "usl"',
        ),
        (
            lambda r: r["loads"][0].update(faces="side"),
            '/loads/0/faces: "side" is not one of',
        ),
        (
            lambda r: r["loads"][0].update(gauss_points=21),
            "/loads/0/gauss_points: must be in",
        ),
        (
            lambda r: r["loads"][0].update(traction=[0, 1]),
            "/loads/0/traction: only used by",
        ),
        (lambda r: r["loads"][0].pop("x_range"), '/loads/0: missing key "x_range"'),
        (
            lambda r: r["loads"][0].update(type="traction", traction=[0, 1]),
            "/loads/0/pressure: not used by type",
        ),
        (
            lambda r: r["loads"][0].update(apply_on="grid"),
            '/loads/0/apply_on: "grid" is not one of',
        ),
        (
            lambda r: r["loads"][0].update(time_function={"type": "ramp"}),
            '/loads/0/time_function: missing key "ramp_time"',
        ),
        (
            lambda r: r["bodies"][0].update(placement="random"),
            '/bodies/0/placement: "random" is not one of',
        ),
    ],
    ids=lambda value: value if isinstance(value, str) else "",
)
def test_bad_keys_are_refused_with_their_pointer(edit, message):
    """Unknown keys and bad values raise CaseError with the C++ reader's message (it validates
    the case: one schema), naming the file and the JSON pointer."""
    raw = shipped("thesis62_bearing_dynamic_zero_start.json")
    edit(raw)
    with pytest.raises(CaseError) as err:
        case_from_dict(raw, "bad.json")
    assert str(err.value).startswith("bad.json: ") and message in str(err.value)


# ------------------------------------------------------------------------- load rule
def test_detected_vertical_pressure_resultant_and_solve():
    """cases/thesis62_bearing_dynamic_zero_start.json with a linear elastic soil: the detected-boundary vertical
    pressure has the resultant (0, -q (x1 - x0)) = (0, -250) kN/m to 1e-10 relative (sum of the
    assembled nodal forces); one elastic solve (gravity switched on, then the load in one step)
    converges and gives the settlement of the same load applied as grid_top_nodes (1e-12).
    """
    raw = elastic_bearing_block()
    case = case_from_dict(raw, "bearing_block_elastic_detected")
    model = Model(case, element_size=1.0)
    force = resultant(model, 0)
    width = 10.0 - 5.0
    print(
        f"\ndetected vertical pressure: resultant ({force[0]:.3e}, {force[1]:.12f}) kN/m"
    )
    assert abs(force[1] + 50.0 * width) <= 1e-10 * 50.0 * width
    assert abs(force[0]) <= 1e-10 * 50.0 * width
    result = run_static(case, model=model, steps=1)
    assert result.converged_to_full_load
    plain = copy.deepcopy(raw)
    plain["loads"] = [
        {"type": "vertical_pressure", "pressure": 50.0, "x_range": [5.0, 10.0]}
    ]
    plain.pop("detection")
    reference = run_static(
        case_from_dict(plain, "grid_top_nodes"), steps=1, element_size=1.0
    )
    settlement, expected = result.curve[-1][1], reference.curve[-1][1]
    print(f"settlement {settlement:.9e} m (grid_top_nodes {expected:.9e} m)")
    assert abs(settlement - expected) <= 1e-12 * expected


# A "C"-like body: base slab 10 x 2 m, a column 0..3 x 2..6 m and an arm 3..5.3 x 4..5 m over
# the slab, so the slab's top between x = 3 and 5.3 lies under the arm.
OVERHANG = [
    [0, 0],
    [10, 0],
    [10, 2],
    [3, 2],
    [3, 4],
    [5.3, 4],
    [5.3, 5],
    [3, 5],
    [3, 6],
    [0, 6],
]


def overhang_case(loads):
    raw = {
        "grid": {"origin": [0, 0], "cell_size": 0.5, "n_cells": [20, 14]},
        "materials": [dict(ELASTIC)],
        "bodies": [{"name": "c", "material": "soil", "polygon": OVERHANG}],
        "boundary_conditions": [{"where": "bottom", "fix": "xy"}],
        "loads": loads,
        "time": {"end_time": 1.0},
    }
    return case_from_dict(raw, "overhang")


def test_load_faces_and_types_on_an_overhang():
    """Exact resultants on the overhang body (q = p = 10 kPa, 1e-10 relative):
    vertical_pressure "top" = q x the loaded x extent (the upper envelope: x in [0, 10] -> 100;
    [4, 8]: the arm's top 4..5.3 plus the slab's top 5.3..8 = 40 kN/m); "upward" also loads the
    slab under the arm (123 and 53 kN/m); on "all" faces in [4, 8] it sums to zero (every
    vertical line crosses the closed boundary an even number of times: the arm's underside and
    the base push up); follower_pressure on all faces of a closed boundary sums to zero;
    traction t on "all" faces in [4, 8] = t x the boundary length there (slab top 4, arm top
    1.3, arm underside 1.3, arm end face 1, base 4: 11.6 m), clipped inside base facets that
    the mesh does not split at x = 4, 8."""

    def vp(x_range, faces):
        return {
            "apply_on": "detected_boundary",
            "type": "vertical_pressure",
            "pressure": 10.0,
            "x_range": x_range,
            "faces": faces,
        }

    loads = [
        vp([0, 10], "top"),
        vp([4, 8], "top"),
        vp([0, 10], "upward"),
        vp([4, 8], "upward"),
        vp([4, 8], "all"),
        {
            "apply_on": "detected_boundary",
            "type": "follower_pressure",
            "pressure": 10.0,
        },
        {
            "apply_on": "detected_boundary",
            "type": "traction",
            "traction": [3.0, -4.0],
            "x_range": [4, 8],
        },
    ]
    case = overhang_case(loads)
    model = Model(case, degree=2, element_size=0.7)
    expected = [
        (0, -100.0),
        (0, -40.0),
        (0, -123.0),
        (0, -53.0),
        (0, 0),
        (0, 0),
        (3.0 * 11.6, -4.0 * 11.6),
    ]
    for k, exact in enumerate(expected):
        got = resultant(model, k)
        print(f"\nload {k} ({loads[k]['type']}, {loads[k].get('faces', 'all')}): {got}")
        scale = max(abs(exact[0]) + abs(exact[1]), 100.0)
        assert np.allclose(got, exact, rtol=0, atol=1e-10 * scale)


def test_interval_material_follows_the_material_in_updated_lagrangian():
    """Updated-Lagrangian geometry stretched by u_x = 0.1 x (mesh moved, as after a converged
    increment): a vertical pressure q = 50 kPa on [5, 10] m with interval "fixed" still loads
    x in [5, 10] (resultant -q 5 m), with "material" the ends moved to 5.5 and 11 m (-q 5.5 m),
    to 1e-10 relative; before the motion (small strain) both are -q 5 m."""
    raw = elastic_bearing_block()
    raw["loads"].append(dict(raw["loads"][0], interval="material"))
    case = case_from_dict(raw, "stretched")
    model = Model(case, degree=2, element_size=1.0, updated_lagrangian=True)
    for k in (0, 1):
        assert abs(resultant(model, k)[1] + 250.0) <= 1e-10 * 250.0
    stretch = np.zeros_like(model.u.x.array).reshape(-1, 2)
    stretch[:, 0] = 0.1 * model.dof_coords0[:, 0]
    model.move_mesh(stretch.ravel())
    fixed, material = resultant(model, 0)[1], resultant(model, 1)[1]
    print(f"\nstretched: fixed {fixed:.12f}, material {material:.12f} kN/m")
    assert abs(fixed + 250.0) <= 1e-10 * 250.0
    assert abs(material + 275.0) <= 1e-10 * 275.0


@pytest.mark.parametrize(
    "shape", ["linear", "gimp", "quadratic_bspline", "cubic_bspline", "quartic_bspline"]
)
def test_every_mpm_shape_function_is_read_and_ignored(shape):
    """The dolfinx model reads the MPM's shape functions as the C++ reader does (README,
    solver.shape_function): it accepts the four and refuses another with its pointer, and
    lists the key as MPM only."""
    raw = shipped("thesis62_bearing_dynamic_zero_start.json")
    raw["solver"]["shape_function"] = shape
    if shape == "quartic_bspline":
        with pytest.raises(
            CaseError, match='/solver/shape_function: "quartic_bspline" is not one of'
        ):
            case_from_dict(raw, "bearing.json")
        return
    case = case_from_dict(raw, "bearing.json")
    assert any("/solver/shape_function: MPM only" in i for i in case.ignored)


def test_a_softening_length_scales_the_law_by_itself_over_the_element_size():
    """materials[].softening_length, as the C++ reader: the cohesion law's plastic strains
    times softening_length / element size (the model's target size), the cohesions unchanged;
    refused on a constant cohesion and when not positive, with its pointer."""
    raw = shipped("thesis62_bearing_dynamic_zero_start.json")
    raw["materials"][0]["softening_length"] = 1.0
    material = case_from_dict(raw, "bearing.json").materials["soil"]
    scaled = material.regularised(0.5)
    assert scaled.cohesion.x == [0.0, 0.1, 0.5]
    assert scaled.cohesion.y == material.cohesion.y == [20.0, 10.0, 5.0]
    assert material.regularised(1.0).cohesion.x == [0.0, 0.05, 0.25]
    for bad, message in (
        (0.0, "/materials/0/softening_length"),
        (-1.0, "/materials/0/softening_length"),
    ):
        raw["materials"][0]["softening_length"] = bad
        with pytest.raises(CaseError, match=message):
            case_from_dict(raw, "bearing.json")
    raw["materials"][0]["softening_length"] = 1.0
    raw["materials"][0]["cohesion"] = 20.0
    with pytest.raises(
        CaseError, match="/materials/0/softening_length: needs a cohesion"
    ):
        case_from_dict(raw, "bearing.json")


def write_quadrilateral_mesh(path, outline, dimension):
    """The four-sided outline meshed by gmsh up to `dimension` (1: its edges, 2: the surface,
    in triangles of about 0.7 m) into `path`, with the physical groups "soil" (the surface),
    "base" (the first edge) and "sides" (the second and fourth)."""
    gmsh = pytest.importorskip("gmsh")
    gmsh.initialize()
    gmsh.option.setNumber("General.Terminal", 0)
    points = [gmsh.model.geo.addPoint(x, y, 0.0, 0.7) for x, y in outline]
    lines = [gmsh.model.geo.addLine(points[k], points[(k + 1) % 4]) for k in range(4)]
    surface = gmsh.model.geo.addPlaneSurface([gmsh.model.geo.addCurveLoop(lines)])
    gmsh.model.geo.synchronize()
    for dim, tags, name in (
        (2, [surface], "soil"),
        (1, [lines[0]], "base"),
        (1, [lines[1], lines[3]], "sides"),
    ):
        gmsh.model.setPhysicalName(dim, gmsh.model.addPhysicalGroup(dim, tags), name)
    gmsh.model.mesh.generate(dimension)
    gmsh.write(str(path))
    gmsh.finalize()


def test_a_mesh_body_is_its_outline(tmp_path):
    """bodies[].mesh, as the C++ reader: the outline of the gmsh file's 2D elements (of the
    physical group) is the body polygon: the same area and corners as the polygon meshed;
    an unknown group and a missing file are refused with the pointer."""
    outline = [(0.0, 0.0), (15.0, 0.0), (12.0, 5.0), (0.0, 5.0)]
    write_quadrilateral_mesh(tmp_path / "block.msh", outline, 2)
    raw = shipped("thesis62_bearing_dynamic_zero_start.json")
    body = raw["bodies"][0]
    for key in ("rectangle", "polygon"):
        body.pop(key, None)
    body.update(mesh="block.msh", physical_group="soil")
    polygon = case_from_dict(raw, str(tmp_path / "case.json")).bodies[0].polygon
    area = 0.5 * sum(
        a[0] * b[1] - b[0] * a[1] for a, b in zip(polygon, polygon[1:] + polygon[:1])
    )
    assert area == pytest.approx(0.5 * (15.0 + 12.0) * 5.0, rel=1e-12)
    for corner in outline:
        assert min(math.dist(corner, v) for v in polygon) <= 1e-12
    body["physical_group"] = "rock"
    with pytest.raises(
        CaseError, match='/bodies/0/mesh: .* no 2D physical group "rock"'
    ):
        case_from_dict(raw, str(tmp_path / "case.json"))
    body.update(mesh="missing.msh", physical_group="soil")
    with pytest.raises(CaseError, match="/bodies/0/mesh: .* is not a readable file"):
        case_from_dict(raw, str(tmp_path / "case.json"))


def test_node_sets_from_a_mesh_fix_the_dofs_of_their_boxes(tmp_path):
    """node_sets[].mesh, as the C++ reader: a physical group of curves gives the nodes on its
    line elements. The elastic block with the bottom fixed through a mesh's "base" curve and
    rollers through its "sides" has the same constrained dofs (every one) as with the same
    sets given as boxes."""
    outline = [(0.0, 0.0), (15.0, 0.0), (15.0, 5.0), (0.0, 5.0)]
    write_quadrilateral_mesh(tmp_path / "edges.msh", outline, 1)
    raw = elastic_bearing_block()
    raw["boundary_conditions"] = [
        {"where": "base", "fix": "xy"},
        {"where": "sides", "fix": "x"},
    ]
    boxes = copy.deepcopy(raw)
    boxes["node_sets"] = [
        {"name": "base", "box": [[0, 0], [15, 0]]},
        {"name": "west", "box": [[0, 0], [0, 5]]},
        {"name": "east", "box": [[15, 0], [15, 5]]},
    ]
    boxes["boundary_conditions"][1:] = [
        {"where": "west", "fix": "x"},
        {"where": "east", "fix": "x"},
    ]
    raw["node_sets"] = [
        {"name": "base", "mesh": "edges.msh", "physical_group": "base"},
        {"name": "sides", "mesh": "edges.msh", "physical_group": "sides"},
    ]
    meshed = case_from_dict(raw, str(tmp_path / "case.json"))
    assert meshed.node_sets["sides"]["segments"].shape[1:] == (2, 2)
    by_box = Model(case_from_dict(boxes, "boxes.json"), element_size=1.0)
    by_mesh = Model(meshed, element_size=1.0)
    assert len(by_box.constrained) > 0
    assert np.array_equal(by_box.constrained, by_mesh.constrained)
