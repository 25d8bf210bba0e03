"""ParaView's own readers on the output series (issue "Fits the tools its users already use",
must-show 2, "ParaView's reader likewise where installed"): with python3-paraview (Debian;
not among the required packages, it is 500 MB) ParaView 5.11 reads particles.xdmf and
particles.pvd (Xdmf3ReaderS, PVDReader) at every output time with each step's own geometry and
fields equal to the HDF5 series to the last bit, and boundary.xdmf and boundary.pvd equal to
boundary_<step>.csv; the reader's times are run.json's. Skipped where ParaView is not
installed."""

import json
from pathlib import Path

import h5py
import numpy as np
import pandas as pd
import pytest

simple = pytest.importorskip(
    "paraview.simple", reason="apt-get install python3-paraview"
)
from vtk import vtkDoubleArray  # noqa: E402
from vtk.util.numpy_support import vtk_to_numpy  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]


def as_numpy(array):
    """A VTK array's values as numpy; copied into an array of interleaved doubles first, as a
    reader may hand out one array per component (vtk_to_numpy reads the memory as
    interleaved)."""
    copy = vtkDoubleArray()
    copy.DeepCopy(array)
    return vtk_to_numpy(copy)


def steps_read_by_paraview(path: Path):
    """[(time, points (n, 3), point data {name: array}), ...] at every time of the file."""
    reader = simple.OpenDataFile(str(path))
    steps = []
    for time in reader.TimestepValues:
        reader.UpdatePipeline(time)
        # The reader's own output after the update at `time` (the built-in session runs the
        # pipeline in this process; Fetch would update it again at another time).
        data = reader.GetClientSideObject().GetOutputDataObject(0)
        arrays = data.GetPointData()
        fields = {
            arrays.GetArrayName(k): as_numpy(arrays.GetArray(k))
            for k in range(arrays.GetNumberOfArrays())
        }
        steps.append((time, as_numpy(data.GetPoints().GetData()), fields))
    simple.Delete(reader)
    return steps


def test_paraview_reads_every_step_of_the_particle_and_boundary_series(
    run_case, tmp_path
):
    case = json.loads(
        (ROOT / "cases" / "thesis62_bearing_dynamic_zero_start.json").read_text()
    )
    case["time"]["end_time"] = 0.25
    case["output"] = {"interval": 0.125, "vtk": True}
    result = run_case(case, tmp_path)
    assert result.returncode == 0, result.stderr
    out = tmp_path / "out"
    outputs = json.loads((out / "run.json").read_text())["outputs"]
    assert len(outputs) == 3
    with h5py.File(out / "particles.h5", "r") as h5:
        for name in ("particles.xdmf", "particles.pvd"):
            steps = steps_read_by_paraview(out / name)
            assert [t for t, _, _ in steps] == [o["time"] for o in outputs], name
            for (time, points, fields), output in zip(steps, outputs):
                group = h5[f"step_{output['step']:08d}"]
                assert np.array_equal(points[:, :2], group["position"][:, :2]), name
                for field in ("sxx", "syy", "eps_p"):
                    assert np.array_equal(fields[field], group[field][:]), (name, field)
        # The series moves: the last step's geometry is not the first's.
        assert not np.array_equal(steps[0][1], steps[-1][1])
    for name in ("boundary.xdmf", "boundary.pvd"):
        steps = steps_read_by_paraview(out / name)
        assert [t for t, _, _ in steps] == [o["time"] for o in outputs], name
        for (time, points, fields), output in zip(steps, outputs):
            csv = pd.read_csv(out / output["boundary"], float_precision="round_trip")
            assert np.array_equal(points[:, :2], csv[["x", "y"]].to_numpy()), name
            assert np.array_equal(fields["loop"], csv["loop"].to_numpy()), name
