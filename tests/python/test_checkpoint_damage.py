"""Damaged checkpoints are refused, never continued (issue "Outputs that survive", check 2).

A short bearing-block run with detection and a load on the detected boundary leaves a
checkpoint; each test damages a copy of its folder in one way and restarts it. Every restart
must either exit 2 naming the damage, or end bitwise where the undamaged restart ends (a flipped
byte that HDF5 never reads). Two families:

* damage to the file's bytes (flips, truncation, other files): the per-dataset CRC-32 or HDF5's
  own reading refuses it;
* values changed with the checksums recomputed, as a buggy writer or an edit by hand would leave
  them: the restart's validation refuses them, naming the dataset.
"""

import json
import shutil
import subprocess
import zlib
from pathlib import Path

import h5py
import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[2]
CHECKSUMS = "t:checksums"


@pytest.fixture(scope="module")
def checkpointed(tmp_path_factory, pfm_binary):
    """(folder of a run with a checkpoint, marked running; the undamaged restart's folder)."""
    base = tmp_path_factory.mktemp("checkpoint")
    case = json.loads(
        (ROOT / "cases" / "thesis62_bearing_dynamic_zero_start.json").read_text()
    )
    case["time"]["end_time"] = 0.6
    case["output"] = {"interval": 0.1, "timeseries_interval": 0.02}
    case["loads"][0]["interval"] = "material"
    case["detection"] = {"method": "improved", "every_steps": 3}
    case_file = base / "case.json"
    case_file.write_text(json.dumps(case))
    run = base / "run"
    subprocess.run(
        [pfm_binary, "run", case_file, "--out", run, "--quiet"]
        + ["--checkpoint-steps", "40", "--threads", "1"],
        check=True,
        capture_output=True,
    )
    status = json.loads((run / "run.json").read_text())
    status["status"] = "running"  # as if killed after its last checkpoint
    (run / "run.json").write_text(json.dumps(status))
    undamaged = base / "undamaged"
    shutil.copytree(run, undamaged)
    restart(pfm_binary, undamaged, expect=0)
    return run, undamaged


def restart(binary, folder, expect=None):
    done = subprocess.run(
        [binary, "run", "--restart", folder, "--quiet", "--threads", "1"],
        capture_output=True,
        text=True,
        timeout=120,
    )
    if expect is not None:
        assert done.returncode == expect, done.stderr
    return done


def rewrite_checksums(path):
    """Recomputes the CRC-32 list over every dataset's bytes, as the writer makes it."""
    with h5py.File(path, "r+") as f:
        lines = []
        for name in sorted(f.keys()):
            if name == CHECKSUMS:
                continue
            data = np.ascontiguousarray(f[name][()])
            lines.append(f"{name} {zlib.crc32(data.tobytes()):08x}\n")
        del f[CHECKSUMS]
        f[CHECKSUMS] = np.frombuffer("".join(lines).encode(), dtype=np.uint8)


def set_values(name, change):
    """A damage that replaces dataset `name` by change(values) and fixes the checksums."""

    def damage(path):
        with h5py.File(path, "r+") as f:
            values = change(np.array(f[name][()]))
            del f[name]
            f[name] = values
        rewrite_checksums(path)

    return damage


def set_text(name, change):
    def damage(path):
        with h5py.File(path, "r+") as f:
            text = change(bytes(np.asarray(f[name][()])).decode())
            del f[name]
            f[name] = np.frombuffer(text.encode(), dtype=np.uint8)
        rewrite_checksums(path)

    return damage


def at(index, value):
    def change(values):
        values[index] = value
        return values

    return change


def flip_byte(fraction):
    def damage(path):
        data = bytearray(path.read_bytes())
        data[min(len(data) - 1, int(fraction * len(data)))] ^= 0x5A
        path.write_bytes(bytes(data))

    return damage


def truncate(keep):
    def damage(path):
        data = path.read_bytes()
        path.write_bytes(data[: keep(len(data))])

    return damage


def remove_dataset(name, keep_checksum=False):
    def damage(path):
        with h5py.File(path, "r+") as f:
            del f[name]
        if not keep_checksum:
            with h5py.File(path, "r+") as f:
                text = bytes(np.asarray(f[CHECKSUMS][()])).decode()
                text = "".join(
                    l + "\n" for l in text.splitlines() if not l.startswith(name)
                )
                del f[CHECKSUMS]
                f[CHECKSUMS] = np.frombuffer(text.encode(), dtype=np.uint8)

    return damage


def fewer_particles(path):
    with h5py.File(path, "r+") as f:
        n = f["n:particles|mass"].shape[0]
        for name in [k for k in f.keys() if k.startswith("n:particles|")]:
            values = np.asarray(f[name][()])
            per_particle = values.shape[0] // n
            del f[name]
            f[name] = values[: (n - 1) * per_particle]
    rewrite_checksums(path)


def negative_jacobian(values):
    values[0:4] = [1.0, 0.0, 0.0, -1.0]  # particle 0's F (column-major 2 x 2)
    return values


def replace_file(content):
    def damage(path):
        path.unlink()
        if content is not None:
            path.write_bytes(content)

    return damage


def make_directory(path):
    path.unlink()
    path.mkdir()


def wrong_checksum(path):
    with h5py.File(path, "r+") as f:
        text = bytes(np.asarray(f[CHECKSUMS][()])).decode()
        name, crc = text.splitlines()[0].split()
        text = text.replace(f"{name} {crc}", f"{name} {int(crc, 16) ^ 1:08x}", 1)
        del f[CHECKSUMS]
        f[CHECKSUMS] = np.frombuffer(text.encode(), dtype=np.uint8)


def extra_dataset(path):
    with h5py.File(path, "r+") as f:
        f["n:unknown|extra"] = np.zeros(3)
    rewrite_checksums(path)


NAN, INF = float("nan"), float("inf")

# (name, damage, a word that the refusal must contain, or None when a bitwise-identical end is
# also acceptable)
DAMAGE = [
    *[
        (f"flip_byte_{f}", flip_byte(f), None)
        for f in (0.0005, 0.002, 0.01, 0.05, 0.2, 0.4)
    ],
    *[(f"flip_byte_{f}", flip_byte(f), None) for f in (0.6, 0.8, 0.95, 0.999)],
    ("truncated_to_0", truncate(lambda n: 0), "checkpoint"),
    ("truncated_to_100", truncate(lambda n: 100), "checkpoint"),
    ("truncated_to_half", truncate(lambda n: n // 2), "checkpoint"),
    ("truncated_by_1", truncate(lambda n: n - 1), "checkpoint"),
    ("random_bytes", replace_file(bytes(range(256)) * 64), "checkpoint"),
    ("missing", replace_file(None), "no checkpoint"),
    ("a_directory", make_directory, "checkpoint"),
    ("checksum_wrong", wrong_checksum, "damaged"),
    ("checksums_missing", remove_dataset(CHECKSUMS, keep_checksum=True), "checksums"),
    ("dataset_missing", remove_dataset("n:particles|velocity"), "particles/velocity"),
    (
        "dataset_missing_listed",
        remove_dataset("n:solver|dt", True),
        "solver/dt is missing",
    ),
    ("fewer_particles", fewer_particles, "particles/reference_position"),
    (
        "position_nan",
        set_values("n:particles|position", at(5, NAN)),
        "particles/position",
    ),
    (
        "velocity_inf",
        set_values("n:particles|velocity", at(0, INF)),
        "particles/velocity",
    ),
    ("stress_nan", set_values("n:particles|stress", at(3, NAN)), "particles/stress"),
    ("volume_zero", set_values("n:particles|volume", at(2, 0.0)), "particles/volume"),
    (
        "volume_negative",
        set_values("n:particles|volume", at(2, -1.0)),
        "particles/volume",
    ),
    (
        "jacobian_negative",
        set_values("n:particles|deformation_gradient", negative_jacobian),
        "deformation_gradient",
    ),
    (
        "plastic_negative",
        set_values("n:particles|plastic_strain", at(1, -0.5)),
        "plastic",
    ),
    (
        "material_99",
        set_values("n:particles|material", at(0, 99.0)),
        "particles/material",
    ),
    ("body_7", set_values("n:particles|body", at(0, 7.0)), "particles/body"),
    ("mass_changed", set_values("n:particles|mass", at(0, 1.0)), "particles/mass"),
    (
        "reference_moved",
        set_values("n:particles|reference_position", at(0, 0.123)),
        "reference_position",
    ),
    ("dt_nan", set_values("n:solver|dt", at(0, NAN)), "solver/dt"),
    ("dt_zero", set_values("n:solver|dt", at(0, 0.0)), "solver/dt"),
    ("dt_doubled", set_values("n:solver|dt", lambda v: 2 * v), "solver/dt"),
    ("step_1e18", set_values("n:solver|step", at(0, 1e18)), "solver/step"),
    ("step_negative", set_values("n:solver|step", at(0, -1.0)), "solver/step"),
    ("step_fraction", set_values("n:solver|step", lambda v: v + 0.5), "solver/step"),
    ("time_nan", set_values("n:solver|time", at(0, NAN)), "solver/time"),
    ("time_shifted", set_values("n:solver|time", lambda v: v + 0.05), "solver/time"),
    ("flag_2", set_values("n:solver|loads_active", at(0, 2.0)), "solver/loads_active"),
    ("damping_negative", set_values("n:solver|damping", at(0, -1.0)), "solver/damping"),
    (
        "energy_nan",
        set_values("n:solver|energy|gravity_work", at(0, NAN)),
        "gravity_work",
    ),
    ("next_output_nan", set_values("n:run|next_output", at(0, NAN)), "run/next_output"),
    (
        "next_series_past",
        set_values("n:run|next_series", at(0, -1e9)),
        "run/next_series",
    ),
    ("outputs_not_json", set_text("t:run|outputs", lambda t: t[:-3]), "run/outputs"),
    (
        "outputs_from_the_future",
        set_text("t:run|outputs", lambda t: t.replace('"step":0', '"step":99999')),
        "run/outputs",
    ),
    (
        "timeseries_header",
        set_text("t:run|timeseries", lambda t: "x" + t),
        "run/timeseries",
    ),
    (
        "boundary_counts",
        set_values("n:coupling|boundary|counts", at(0, 1e6)),
        "coupling/boundary/counts",
    ),
    ("load_end_1e9", set_values("n:coupling|load_ends", at(0, 1e9)), "load_ends"),
    (
        "detector_shape_size",
        set_values("n:coupling|detector|shape", lambda v: np.append(v, 1.0)),
        "coupling/detector/shape",
    ),
    ("extra_dataset", extra_dataset, None),
]


@pytest.mark.parametrize("name,damage,word", DAMAGE, ids=[d[0] for d in DAMAGE])
def test_damaged_checkpoint_is_refused(
    pfm_binary, checkpointed, tmp_path, name, damage, word
):
    run, undamaged = checkpointed
    folder = tmp_path / "run"
    shutil.copytree(run, folder)
    damage(folder / "checkpoint.h5")
    done = restart(pfm_binary, folder)
    assert done.returncode in (0, 2), f"{name}: exit {done.returncode}\n{done.stderr}"
    if done.returncode == 2:
        assert "checkpoint" in done.stderr and (
            word is None or word in done.stderr
        ), done.stderr
        # Refused before anything was written: the folder's state is as it was.
        assert json.loads((folder / "run.json").read_text())["status"] == "running"
        return
    assert word is None, f"{name}: a damaged checkpoint was continued"
    for output in ("final_particles.csv", "timeseries.csv"):
        assert (folder / output).read_bytes() == (
            undamaged / output
        ).read_bytes(), output


def test_at_least_forty_kinds_of_damage():
    assert len(DAMAGE) >= 40
