"""VTK XML output (issue "Fits the tools its users already use", item 2): with ``output.vtk`` every
output step also writes particles_<step>.vtu (zlib-compressed binary, a vertex per point) and,
with detection, boundary_<step>.vtu (the loops as 2-node line cells); particles.pvd and
boundary.pvd list them with their times, for the MPM and the UL-FEM. meshio reads every step's
positions and fields equal to the HDF5 series, the boundary equal to boundary_<step>.csv, and
the last step equal to final_particles.csv, to the last bit; the .pvd's times are run.json's
outputs."""

import json
import xml.etree.ElementTree as ElementTree
from pathlib import Path

import h5py
import numpy as np
import pandas as pd
import pytest

meshio = pytest.importorskip("meshio")

ROOT = Path(__file__).resolve().parents[2]
CASE = ROOT / "cases" / "thesis62_bearing_dynamic_zero_start.json"


@pytest.mark.parametrize("solver", ["mpm", "ulfem"])
def test_every_vtu_step_reads_back_as_the_hdf5_series(run_case, tmp_path, solver):
    case = json.loads(CASE.read_text())
    case["time"]["end_time"] = 0.25
    case["output"] = {"interval": 0.125, "vtk": True}
    result = run_case(case, tmp_path, "--solver", solver)
    assert result.returncode == 0, result.stderr
    out = tmp_path / "out"
    run = json.loads((out / "run.json").read_text())
    pvd = ElementTree.parse(out / "particles.pvd").getroot()
    sets = pvd.find("Collection").findall("DataSet")
    assert [float(s.get("timestep")) for s in sets] == [
        o["time"] for o in run["outputs"]
    ]
    with h5py.File(out / "particles.h5", "r") as h5:
        for entry, dataset in zip(run["outputs"], sets):
            mesh = meshio.read(out / dataset.get("file"))
            step = h5[f"step_{entry['step']:08d}"]
            assert np.array_equal(mesh.points, step["position"][:])
            assert mesh.cells[0].type == "vertex"
            for name in ("sxx", "syy", "sxy", "szz", "eps_p", "volume", "F11", "F22"):
                assert np.array_equal(mesh.point_data[name], step[name][:]), name
            for name in ("displacement", "velocity"):
                assert np.array_equal(mesh.point_data[name], step[name][:]), name
            for name in ("id", "material", "body"):
                assert np.array_equal(mesh.point_data[name], step[name][:]), name
    if solver == "mpm":  # the detected boundary: its points and loops as in the CSV
        boundary = ElementTree.parse(out / "boundary.pvd").getroot()
        files = [d.get("file") for d in boundary.find("Collection").findall("DataSet")]
        assert len(files) == len(run["outputs"])
        for entry, name in zip(run["outputs"], files):
            mesh = meshio.read(out / name)
            table = pd.read_csv(out / entry["boundary"], float_precision="round_trip")
            assert np.array_equal(mesh.points[:, :2], table[["x", "y"]].to_numpy())
            assert np.array_equal(mesh.point_data["loop"], table["loop"].to_numpy())
            lines = mesh.cells[0].data
            assert mesh.cells[0].type == "line" and len(lines) >= len(table) - 1
            loop = table["loop"].to_numpy()
            assert np.array_equal(loop[lines[:, 0]], loop[lines[:, 1]])
    final = pd.read_csv(out / "final_particles.csv", float_precision="round_trip")
    last = meshio.read(out / sets[-1].get("file"))
    assert np.array_equal(last.points[:, 0], final["x"].to_numpy())
    assert np.array_equal(last.points[:, 1], final["y"].to_numpy())
    assert np.array_equal(last.point_data["sxx"], final["sxx"].to_numpy())
    # zlib at work: the step is smaller than its arrays in base64 without compression (185
    # bytes per point: 20 float64 values, id, connectivity and offset as int64, material and
    # body as int32, the cell type as uint8; x 4/3 for base64)
    uncompressed = len(final) * 185 * 4 / 3
    assert (out / sets[-1].get("file")).stat().st_size < 0.8 * uncompressed
