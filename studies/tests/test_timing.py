"""Per-stage timing tables from run.json summaries."""

import pandas as pd

from studies import timing


def test_stage_rows_per_step_and_mpm_step_excludes_detection():
    summary = {"n_steps": 10, "stage_seconds": {"stress": 0.5, "particles_to_grid": 0.3,
                                                 "detect": 0.4}}
    rows = {r["stage"]: r["seconds_per_step"] for r in timing.stage_rows(summary, {"case": "c"})}
    assert rows == {"stress": 0.05, "particles_to_grid": 0.03, "detect": 0.04,
                    "mpm_step": 0.08}


def test_summarise_gives_median_and_spread_of_repetitions():
    raw = pd.DataFrame({"case": "c", "n_particles": 100, "threads": 1, "detector": "d",
                        "stage": "stress", "repetition": range(5),
                        "seconds_per_step": [5.0, 1.0, 3.0, 2.0, 4.0]})
    row = timing.summarise(raw).iloc[0]
    assert (row["median"], row["min"], row["max"], row["q25"], row["q75"],
            row["repetitions"]) == (3.0, 1.0, 5.0, 2.0, 4.0, 5)


def test_block_case_has_the_requested_number_of_points():
    for n in (1_000, 30_000, 300_000):
        case = timing.block_case(n, "pfm_improved", steps=10)
        (x0, y0), (x1, y1) = case["bodies"][0]["rectangle"]
        points = round((x1 - x0) / timing.CELL_SIZE) * round((y1 - y0) / timing.CELL_SIZE) * 4
        assert abs(points - n) / n <= 0.02
        assert abs(case["time"]["end_time"] / case["time"]["dt"] - 10) <= 1e-9
