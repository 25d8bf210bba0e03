"""Write the seed inputs of the four fuzz targets into DIR/<target>/ (used once by `make fuzz`
before a run; the committed corpora in tests/fuzz/corpus/ are minimised fuzzer output grown
from these seeds). Seeds: the shipped cases, the malformed cases of
tests/python/test_case_validation.py, detector configurations, boundary-load entries, small
particle CSV files, valid and invalid, and detector clouds (the byte layout of decode_detect()
in tests/fuzz/fuzz_harness.cpp).

Usage: /usr/bin/python3 tests/fuzz/make_seeds.py DIR
"""

import copy
import hashlib
import json
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def put(directory: Path, text) -> None:
    data = text.encode() if isinstance(text, str) else text
    directory.mkdir(parents=True, exist_ok=True)
    (directory / hashlib.sha1(data).hexdigest()).write_bytes(data)


def case_seeds():
    seeds = [p.read_text() for p in sorted((ROOT / "cases").glob("*.json"))]
    sys.path.insert(0, str(ROOT / "tests" / "python"))
    import test_case_validation as tcv  # the malformed cases, reused as seeds

    for name, document, _ in tcv.MALFORMED:
        if isinstance(document, dict):
            seeds.append(json.dumps(document))
        elif isinstance(document, str) and document != "TRUNCATED":
            seeds.append(document)
    base = json.loads(
        (ROOT / "cases" / "thesis62_bearing_dynamic_zero_start.json").read_text()
    )
    seeds.append(
        json.dumps(base).replace('"youngs_modulus": 1000.0', '"youngs_modulus": 1e999')
    )
    seeds.append(json.dumps(base)[:300])
    rich = copy.deepcopy(base)
    rich["materials"].append(
        {
            "name": "mc",
            "model": "mohr_coulomb",
            "youngs_modulus": 5e4,
            "poisson_ratio": 0.3,
            "unit_weight": 18,
            "cohesion": {"table": [[0, 10], [0.1, 5]]},
            "friction_angle": 30,
            "dilation_angle": 5,
            "tension_cutoff": 1,
        }
    )
    rich["materials"].append(
        {
            "name": "el",
            "model": "linear_elastic",
            "youngs_modulus": 1e5,
            "poisson_ratio": 0.2,
            "unit_weight": 0,
        }
    )
    rich["bodies"].append(
        {
            "name": "tri",
            "material": "mc",
            "polygon": [[1, 5], [3, 5], [2, 6], [1, 5]],
            "points_per_cell": 3,
            "placement": "gauss",
        }
    )
    rich["node_sets"] = [{"name": "foot", "box": [[0, 0], [1, 1]]}]
    rich["boundary_conditions"].append({"where": "foot", "fix": "y"})
    rich["loads"].append(
        {
            "type": "vertical_pressure",
            "pressure": 5,
            "x_range": [0, 1],
            "time_function": {"type": "ramp", "ramp_time": 0.5},
        }
    )
    rich["loads"].append(
        {
            "apply_on": "detected_boundary",
            "type": "traction",
            "traction": [1, 2],
            "curve": "cubic",
            "integration": "thesis",
            "gauss_points": 3,
            "split_at_cell_edges": False,
            "scale_eq_6_15": True,
            "redistribute_lost_load": True,
            "interval": "material",
        }
    )
    rich["initial_stress"] = {
        "method": "gravity",
        "kinetic_energy_ratio": 1e-5,
        "damping": 0.5,
        "max_time": 3,
    }
    rich["gravity"] = {"g": 9.81, "ramp_time": 0.1}
    rich["solver"] = {"scheme": "usl", "shape_function": "gimp", "damping": 0.1}
    rich["time"] = {"end_time": 1, "cfl": 0.3, "dt": 1e-4}
    rich["output"] = {"interval": 0.1, "timeseries_interval": 0.01}
    rich["detection"] = {"method": "pfm", "pfm": {"refinement": 2}}
    seeds.append(json.dumps(rich, indent=1))
    huge = copy.deepcopy(base)
    huge["grid"]["n_cells"] = [2147483647, 1]
    seeds.append(json.dumps(huge))
    huge["grid"]["n_cells"] = [7000, 7000]
    seeds.append(json.dumps(huge))
    return seeds


DETECTOR_SEEDS = [
    {},
    {"method": "improved"},
    {
        "method": "pfm",
        "pfm": {
            "kernel_factor": 1.5,
            "contour_level": 0,
            "refinement": 2,
            "negative_outside": True,
            "deformation": "large_strain",
            "min_size_factor": 0.5,
            "max_size_factor": 2,
            "edge_location": "shape_functions",
            "bisection_steps": 100,
            "bisection_tolerance": 1e-4,
            "remove_vertex_holes": False,
            "gaussian_sigma": 1,
            "gaussian_size": 5,
            "median_weights": [1, 2, 3],
        },
    },
    {
        "method": "improved",
        "improved": {
            "profile": "biweight",
            "radius_factor": 2,
            "level": 0.5,
            "guard_factor": 0.6,
            "guard_margin": 0.02,
            "refinement": 0,
            "max_refinement": 32,
            "saddle_rule": "centre_sample",
            "narrow_band": False,
            "band_margin": 0.4,
            "root_tolerance": 1e-6,
            "curvature_correction": True,
            "neighbour_shape": 0.7,
        },
    },
    {"method": "smm", "smm": {}},
    {"method": "vof", "vof": {"x": 1}, "density": {}},
    {"improved": {"levle": 0.5}},
    {"pfm": {"median_weights": [1, 2]}},
    {"pfm": {"refinement": 1e10}},
]

LOAD_SEEDS = [
    {
        "apply_on": "detected_boundary",
        "type": "vertical_pressure",
        "pressure": 100,
        "x_range": [5, 10],
        "time_function": {"type": "ramp", "ramp_time": 0.5},
    },
    {
        "apply_on": "detected_boundary",
        "type": "follower_pressure",
        "pressure": -3,
        "faces": "all",
        "curve": "catmull_rom",
        "integration": "exact",
        "gauss_points": 20,
        "split_at_cell_edges": True,
    },
    {
        "apply_on": "detected_boundary",
        "type": "traction",
        "traction": [1, 2],
        "x_range": [0, 1],
        "curve": "quadratic",
        "interval": "material",
    },
    {
        "apply_on": "detected_boundary",
        "type": "traction",
        "traction": [1, 2],
        "pressure": 3,
    },
    {"apply_on": "grid_top_nodes", "type": "traction", "traction": [1, 2]},
]


def config_seeds():
    return [json.dumps(d) for d in DETECTOR_SEEDS + LOAD_SEEDS] + [
        json.dumps(
            {
                "method": "improved",
                "initial_spacing": 0.25,
                "grid": {"origin": [0, 0], "cell_size": 0.5, "n_cells": [14, 12]},
            }
        )
    ]


def csv_seeds():
    block = "id,x,y,volume,F11,F12,F21,F22\n" + "".join(
        f"{3 * j + i},{0.125 + 0.25 * i},{0.125 + 0.25 * j},0.0625,1,0,0,1\n"
        for j in range(3)
        for i in range(3)
    )
    return [
        block,
        "x,y,volume\n1,2,0.1\n1.5,2,0.1\n",
        "# comment\n\nx, y, volume\r\n1.0, 2.0, 0.25\r\n\n# tail\n",
        "volume,y,x,extra\n0.1,2,1,abc\n",
        "x,y,volume,F11,F12,F21,F22\n0,0,1,1.1,0.1,-0.1,0.9\n",
        "x,y,volume,F11\n0,0,1,1\n",
        "x,y,volume\n1,2\n",
        "x,y,volume\n1,2,0.1,\n",
        "x,y,volume\n1,2,-0.1\n",
        "x,y,volume\n1,2,nan\n",
        "x,y,volume\ninf,2,1\n",
        "x,y,volume\n1e999,2,1\n",
        "x,y,volume\n0x10,2,1\n",
        "x,y,volume,F11,F12,F21,F22\n0,0,1,0,1,1,0\n",
        "x,y\n1,2\n",
        "x,y,volume\n",
        "",
        "x,x,y,volume\n1,2,3,4\n",
    ]


def detect_seeds():
    """Blocks, sheared and stretched blocks, blocks with free points around them, scattered
    points: header (grid, points per cell and flags, block, block F) then 8 bytes per point.
    """

    def cloud(nx, ny, flags, block, block_f=(128, 128, 128, 128), points=()):
        data = bytes([nx, ny, flags, *block, *block_f])
        for x, y, f in points:
            data += bytes([x >> 8, x & 255, y >> 8, y & 255, *f])
        return data

    identity = (128, 128, 128, 128)
    ring = [
        (20000 + (i * 7919) % 25000, 20000 + (i * 104729) % 25000, identity)
        for i in range(24)
    ]
    return [
        cloud(7, 5, 0, (4, 4, 20, 12)),
        cloud(7, 5, 1, (0, 0, 30, 9)),
        cloud(9, 9, 4, (6, 6, 20, 20), (180, 150, 128, 100)),
        cloud(9, 9, 4 | 2, (6, 6, 30, 24), (128, 200, 90, 128)),
        cloud(5, 5, 8, (2, 2, 10, 10), identity, ring[:8]),
        cloud(
            9,
            7,
            4,
            (0, 0, 0, 0),
            identity,
            [(x, y, (170, 100, 150, 90)) for x, y, _ in ring],
        ),
        cloud(9, 9, 3, (10, 10, 12, 3), identity, ring[8:]),
        # Kernels shaped by the neighbours: a row one point thick, a sheared block with free
        # points.
        cloud(9, 7, 16, (4, 10, 30, 11)),
        cloud(9, 9, 16 | 4, (6, 6, 20, 20), (180, 150, 128, 100), ring[:8]),
    ]


def main() -> None:
    out = Path(sys.argv[1])
    for seed in case_seeds():
        put(out / "case", seed)
    for seed in csv_seeds():
        put(out / "particle_csv", seed)
    for seed in config_seeds():
        put(out / "config", seed)
    for seed in detect_seeds():
        put(out / "detect", seed)
    for target in ("case", "particle_csv", "config", "detect"):
        print(target, len(list((out / target).iterdir())), "seeds")


if __name__ == "__main__":
    main()
