"""HDF5 outputs as readers expect them (issue "Fits the tools its users already use", item 2):
every step group carries its time and step, the file its units; id, material, body and the
boundary's loop are integers; with output.compression "gzip" the datasets are gzip-compressed
with byte shuffle (contiguous without); and h5py reads back at the last output step exactly
what final_particles.csv and boundary_<step>.csv hold."""

import json
import subprocess
from pathlib import Path

import h5py
import numpy as np
import pandas as pd

ROOT = Path(__file__).resolve().parents[2]


def run_thesis_block(pfm_binary, tmp_path, end_time, output):
    """cases/thesis62_bearing_dynamic_zero_start.json to end_time with the output block
    `output`; returns the output folder."""
    case = json.loads(
        (ROOT / "cases" / "thesis62_bearing_dynamic_zero_start.json").read_text()
    )
    case["time"]["end_time"] = end_time
    case["output"] = output
    path = tmp_path / "case.json"
    path.write_text(json.dumps(case))
    out = tmp_path / "out"
    subprocess.run(
        [pfm_binary, "run", path, "--out", out, "--quiet"],
        check=True,
        capture_output=True,
    )
    return out


def test_hdf5_steps_read_back_as_the_csv_files(pfm_binary, tmp_path):
    out = run_thesis_block(
        pfm_binary, tmp_path, 0.5, {"interval": 0.25, "compression": "gzip"}
    )
    outputs = json.loads((out / "run.json").read_text())["outputs"]
    final = pd.read_csv(out / "final_particles.csv", float_precision="round_trip")
    with h5py.File(out / "particles.h5", "r") as f:
        assert "kPa" in f.attrs["units"].decode()
        for entry in outputs:
            group = f[f"step_{entry['step']:08d}"]
            assert group.attrs["time"] == entry["time"]
            assert group.attrs["step"] == entry["step"]
        last = f[f"step_{outputs[-1]['step']:08d}"]
        for name in ("id", "material", "body"):
            assert last[name].dtype == np.int64, name
        assert last["position"].compression == "gzip" and last["position"].shuffle
        np.testing.assert_array_equal(last["position"][:, 0], final["x"])
        np.testing.assert_array_equal(last["position"][:, 1], final["y"])
        np.testing.assert_array_equal(last["velocity"][:, 0], final["vx"])
        for name in ("sxx", "syy", "sxy", "szz", "eps_p", "volume", "F11", "F22"):
            np.testing.assert_array_equal(last[name][:], final[name], err_msg=name)
        np.testing.assert_array_equal(last["id"][:], final["id"])
    boundary = pd.read_csv(out / outputs[-1]["boundary"], float_precision="round_trip")
    with h5py.File(out / "boundary.h5", "r") as f:
        last = f[f"step_{outputs[-1]['step']:08d}"]
        assert last.attrs["time"] == outputs[-1]["time"]
        assert last["loop"].dtype == np.int64 and last["segments"].dtype == np.int64
        np.testing.assert_array_equal(last["position"][:, 0], boundary["x"])
        np.testing.assert_array_equal(last["position"][:, 1], boundary["y"])
        np.testing.assert_array_equal(last["loop"][:], boundary["loop"])


def test_the_ulfem_mesh_carries_each_elements_mean_stress(pfm_binary, tmp_path):
    """mesh.h5 of a UL-FEM run: per element, sxx, syy, sxy, szz and eps_p are the
    volume-weighted means of its four Gauss points (points 4 e .. 4 e + 3 of
    final_particles.csv); the column under its weight and surcharge has syy < 0 everywhere,
    and meshio reads the five as cell data from mesh.xdmf."""
    out = tmp_path / "out"
    subprocess.run(
        [pfm_binary, "run", ROOT / "cases" / "column.json", "--out", out, "--quiet"]
        + ["--solver", "ulfem"],
        check=True,
        capture_output=True,
    )
    final = pd.read_csv(out / "final_particles.csv", float_precision="round_trip")
    final = final.sort_values("id")
    last_step = json.loads((out / "run.json").read_text())["outputs"][-1]["step"]
    volume = final["volume"].to_numpy().reshape(-1, 4)
    with h5py.File(out / "mesh.h5", "r") as f:
        last = f[f"step_{last_step:08d}"]
        assert last["syy"].shape == (len(final) // 4,)
        for name in ("sxx", "syy", "sxy", "szz", "eps_p"):
            values = final[name].to_numpy().reshape(-1, 4)
            expected = (values * volume).sum(axis=1) / volume.sum(axis=1)
            np.testing.assert_allclose(last[name][:], expected, rtol=1e-13, atol=1e-12)
        assert (last["syy"][:] < 0).all()
    import meshio

    with meshio.xdmf.TimeSeriesReader(str(out / "mesh.xdmf")) as reader:
        reader.read_points_cells()
        _, _, cell_data = reader.read_data(reader.num_steps - 1)
    with h5py.File(out / "mesh.h5", "r") as f:
        for name in ("sxx", "syy", "sxy", "szz", "eps_p"):
            np.testing.assert_array_equal(
                cell_data[name][0], f[f"step_{last_step:08d}"][name]
            )


def test_meshio_reads_every_steps_positions_and_fields(pfm_binary, tmp_path):
    """meshio's TimeSeriesReader keeps the first step's geometry for the whole series; the
    XDMF gives each step's positions again as the point data "position". For every output step
    of a collapsing block: positions and fields equal to particles.h5 (h5py) bit for bit, and at
    the last step to final_particles.csv; the boundary's positions and loops per step equal to
    boundary_<step>.csv."""
    import meshio

    out = run_thesis_block(pfm_binary, tmp_path, 1.0, {"interval": 0.25})
    outputs = json.loads((out / "run.json").read_text())["outputs"]
    with meshio.xdmf.TimeSeriesReader(str(out / "particles.xdmf")) as reader:
        reader.read_points_cells()
        assert reader.num_steps == len(outputs)
        steps = [reader.read_data(k) for k in range(reader.num_steps)]
    moved = 0.0
    with h5py.File(out / "particles.h5", "r") as f:
        for entry, (time, data, _) in zip(outputs, steps):
            group = f[f"step_{entry['step']:08d}"]
            assert time == entry["time"]
            np.testing.assert_array_equal(data["position"], group["position"][:])
            for name in ("sxx", "syy", "eps_p", "volume"):
                np.testing.assert_array_equal(data[name], group[name][:], err_msg=name)
            moved = max(moved, np.abs(data["position"] - steps[0][1]["position"]).max())
    assert moved > 0.1  # m: the points move, so the first geometry would be wrong
    final = pd.read_csv(out / "final_particles.csv", float_precision="round_trip")
    np.testing.assert_array_equal(steps[-1][1]["position"][:, 0], final["x"])
    np.testing.assert_array_equal(steps[-1][1]["position"][:, 1], final["y"])
    with meshio.xdmf.TimeSeriesReader(str(out / "boundary.xdmf")) as reader:
        reader.read_points_cells()
        boundaries = [reader.read_data(k)[1] for k in range(reader.num_steps)]
    assert len(boundaries) == len(outputs)
    for entry, data in zip(outputs, boundaries):
        csv = pd.read_csv(out / entry["boundary"], float_precision="round_trip")
        np.testing.assert_array_equal(data["position"][:, 0], csv["x"])
        np.testing.assert_array_equal(data["position"][:, 1], csv["y"])
        np.testing.assert_array_equal(data["loop"], csv["loop"])
