"""Synthetic outputs of the C++ tools, with values chosen so the expected maxima are known."""

import itertools

import numpy as np
import pandas as pd

from studies.quadrature import K_VALUES, MODES, SPLITS


def map_error(mode, k, split, cx, cy):
    """Thesis formula: error growing away from the line A-B, 1/k-weighted (max at C = (1, 1));
    exact formula with splitting: rounding-level; exact without splitting: small."""
    if mode == "thesis":
        return 0.14 * (abs(cx + cy) / 2.0) * (5.0 / k)
    return 1e-16 * (1 + cx * cx) if split else 1e-3 / k * abs(cx - cy) / 2.0


def error_map(resolution=5, k_values=K_VALUES) -> pd.DataFrame:
    axis = np.linspace(-1.0, 1.0, resolution)
    rows = []
    for mode, k, split, cx, cy in itertools.product(
        MODES, k_values, SPLITS, axis, axis
    ):
        e = map_error(mode, k, split, cx, cy)
        rows.append(
            {
                "cx": cx,
                "cy": cy,
                "mode": mode,
                "k": k,
                "split": split,
                "total_force_rel_error": e,
                "nodal_force_rel_error": 2 * e,
            }
        )
    return pd.DataFrame(rows)


def random_segments(n=7, k_values=K_VALUES) -> pd.DataFrame:
    rows = []
    for segment, mode, k, split in itertools.product(range(n), MODES, k_values, SPLITS):
        scale = 0.1 if mode == "thesis" else (1e-15 if split else 1e-4)
        rows.append(
            {
                "segment": segment,
                "n_cells_crossed": 1 + segment % 3,
                "mode": mode,
                "k": k,
                "split": split,
                "nodal_force_rel_error": scale * (segment + 1),
                "total_force_rel_error": scale * (segment + 1) / 2,
            }
        )
    return pd.DataFrame(rows)


FAKE_TOOL = """#!{python}
import sys
sys.path.insert(0, {root!r})
import argparse, pathlib
from studies.tests import synthetic
parser = argparse.ArgumentParser()
parser.add_argument("--out", required=True)
parser.add_argument("--resolution", type=int, default=201)
parser.add_argument("--random-segments", type=int, default=1000)
parser.add_argument("--seed", type=int, default=1)
args = parser.parse_args()
out = pathlib.Path(args.out)
out.mkdir(parents=True, exist_ok=True)
# k = 5 only: the thesis's k, enough for every metric, and a quick figure to draw.
synthetic.error_map(5, (5,)).to_csv(out / "error_map.csv", index=False)
synthetic.random_segments(7, (5,)).to_csv(out / "random_segments.csv", index=False)
with open(out.parent / "calls.txt", "a") as f:
    f.write(" ".join(sys.argv[1:]) + "\\n")
"""
