"""Per-stage timing tables from run.json summaries."""

import pandas as pd

from studies import timing


def test_stage_rows_per_step_and_mpm_step_excludes_detection():
    # 10 steps, detection every 2 steps: 5 calls inside the steps + 1 for the output at step 0;
    # the in-step share (5/6) of detect + bezier + traction sits inside external_forces.
    summary = {
        "n_steps": 10,
        "stage_seconds": {
            "stress": 0.5,
            "particles_to_grid": 0.3,
            "external_forces": 0.6,
            "detect": 0.6,
            "bezier": 0.06,
            "traction": 0.06,
        },
        "detection": {"calls": 6, "every_steps": 2, "seconds_per_call": 0.1},
    }
    rows = {
        r["stage"]: r["seconds_per_step"]
        for r in timing.stage_rows(summary, {"case": "c"})
    }
    assert rows.keys() == {
        "stress",
        "particles_to_grid",
        "external_forces",
        "detect",
        "bezier",
        "traction",
        "external_forces_mpm",
        "mpm_step",
        "detect_per_call",
    }
    assert abs(rows["external_forces_mpm"] - (0.6 - 0.72 * 5 / 6) / 10) <= 1e-15
    assert abs(rows["mpm_step"] - (0.5 + 0.3 + 0.6 - 0.6) / 10) <= 1e-15
    assert rows["detect_per_call"] == 0.1
    plain = {"n_steps": 10, "stage_seconds": {"stress": 0.5, "external_forces": 0.1}}
    rows = {
        r["stage"]: r["seconds_per_step"]
        for r in timing.stage_rows(plain, {"case": "c"})
    }
    assert abs(rows["mpm_step"] - 0.06) <= 1e-15 and "detect_per_call" not in rows


def test_summarise_gives_median_and_spread_of_repetitions():
    raw = pd.DataFrame(
        {
            "case": "c",
            "n_particles": 100,
            "threads": 1,
            "detector": "d",
            "stage": "stress",
            "repetition": range(5),
            "seconds_per_step": [5.0, 1.0, 3.0, 2.0, 4.0],
        }
    )
    row = timing.summarise(raw).iloc[0]
    assert (
        row["median"],
        row["min"],
        row["max"],
        row["q25"],
        row["q75"],
        row["repetitions"],
    ) == (3.0, 1.0, 5.0, 2.0, 4.0, 5)


def test_block_case_has_the_requested_number_of_points():
    for n in (1_000, 30_000, 300_000):
        case = timing.block_case(n, "pfm_improved", steps=10)
        (x0, y0), (x1, y1) = case["bodies"][0]["rectangle"]
        points = (
            round((x1 - x0) / timing.CELL_SIZE)
            * round((y1 - y0) / timing.CELL_SIZE)
            * 4
        )
        assert abs(points - n) / n <= 0.02
        assert abs(case["time"]["end_time"] / case["time"]["dt"] - 10) <= 1e-9


def test_failure_state_case_is_the_state_case_without_its_detected_boundary():
    # The 150 kPa collapse from K0: its K0 start and CFL 0.2, run 0.5 s; its load on the
    # detected boundary goes with the detection it needs.
    state = {
        "name": "bearing_150kPa_k0_t2.5",
        "case": "thesis62_bearing_dynamic_zero_start",
        "overrides": {
            "loads": {"0": {"pressure": 150.0}},
            "initial_stress": {"method": "k0"},
            "time": {"cfl": 0.2},
        },
    }
    case, path = timing.state_case(state)
    assert path.name == "thesis62_bearing_dynamic_zero_start.json"
    assert case["initial_stress"]["method"] == "k0"
    assert case["time"]["cfl"] == 0.2
    assert case["time"]["end_time"] == timing.FAILURE_STEP_TIME
    assert "detection" not in case
    assert all(
        entry.get("apply_on") != "detected_boundary"
        for block in ("loads", "constraints")
        for entry in case.get(block, [])
    )


def test_failure_state_table_takes_the_median_call_against_the_step():
    rows = [
        {
            "state": "s",
            "n_particles": 10,
            "detector": "d",
            "repetition": k,
            "detect_s": t,
        }
        | {"mpm_step_s": 0.5}
        for k, t in enumerate((3.0, 1.0, 2.0))
    ]
    table = timing.failure_state_table(rows)
    assert len(table) == 1
    row = table.iloc[0]
    assert row["detect_s"] == 2.0 and row["calls"] == 3
    assert row["detect_to_step_ratio"] == 4.0
