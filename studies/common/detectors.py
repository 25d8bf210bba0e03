"""The detectors the studies compare, by the keys of the report (studies.report.headline).

Every detector but the library baseline runs inside ``pfm-mpm`` (a ``detection`` block in the
case, or ``pfm-mpm detect`` on a particle file) with the configuration below: the defaults of
mpm/detect/detector.hpp for the plain thesis PFM (``pfm_thesis``: fixed kernels, no filter,
contour level 0) and the improved detector (``pfm_improved``), the thesis PFM as the thesis
finally ran it (``pfm_thesis_final``, THESIS_FINAL_PFM) and with the median filter it tried
instead (``pfm_thesis_median``, THESIS_MEDIAN_PFM). The library baseline (scikit-image,
``studies/detectors/skimage_detector.py``) only post-processes particle files: its "total"
boundary is computed on the particles of the MPM run that used the improved detector.
"""

from __future__ import annotations

import copy
from typing import Optional

from studies.report.headline import DETECTORS

LIBRARY = "library"
# The thesis PFM as the thesis finally ran it: kernels deformed by the small-strain rule
# (eq. 4.17) within the size limits s_min = 2/3 s_0, s_max = 2 s_0 (eq. 5.11, fig. 5.29), the
# field smoothed by the Gaussian filter with sigma = 1 (5.3.1, which needs the edge points from
# the cells' shape functions) and contoured at the lowered level z = -30 that brings the
# filtered surface back out to the unfiltered one (fig. 5.22; the thesis's field units, those of
# mpm/detect: unit-volume kernels, 1/m^2). The advice of 7.1 and the runs of 6.2.
THESIS_FINAL_PFM = {
    "deformation": "small_strain",
    "min_size_factor": 2.0 / 3.0,
    "max_size_factor": 2.0,
    "edge_location": "shape_functions",
    "gaussian_sigma": 1.0,
    "contour_level": -30.0,
}
# The thesis's other filter (5.3.2, eq. 5.10), which it tried and dropped: the median of each
# node's proximity and its eight neighbours' (weights a = b = c = 1) in place of the Gaussian,
# with the same kernels and edge location, at the unlowered level z = 0 (a median keeps the
# field's level).
THESIS_MEDIAN_PFM = {
    **{
        k: v
        for k, v in THESIS_FINAL_PFM.items()
        if k not in ("gaussian_sigma", "contour_level")
    },
    "median_weights": [1, 1, 1],
}
METHODS = {
    "pfm_thesis": {"method": "pfm"},
    "pfm_thesis_final": {"method": "pfm", "pfm": THESIS_FINAL_PFM},
    "pfm_thesis_median": {"method": "pfm", "pfm": THESIS_MEDIAN_PFM},
    "pfm_improved": {"method": "improved"},
    "smm": {"method": "smm"},
    "vof": {"method": "vof"},
    "density": {"method": "density"},
    LIBRARY: {"method": "skimage"},
}
assert set(METHODS) == {key for key, _ in DETECTORS}
# The run whose particles the library baseline post-processes ("total" measure).
LIBRARY_HOST = "pfm_improved"


def in_run(detector: str) -> bool:
    """Whether pfm-mpm can run this detector during a simulation."""
    return detector != LIBRARY


def detection_block(detector: str, every_steps: int = 1) -> dict:
    """The case's ``detection`` block for an in-run detector."""
    if not in_run(detector):
        raise ValueError(f"{detector} does not run inside pfm-mpm")
    block = copy.deepcopy(METHODS[detector])
    if every_steps != 1:
        block["every_steps"] = every_steps
    return block


def detect_config(
    detector: str, grid: dict, initial_spacing: Optional[float] = None
) -> dict:
    """The ``--config`` of ``pfm-mpm detect`` (or of the library baseline): the method, the
    MPM grid and the initial particle spacing."""
    config = copy.deepcopy(METHODS[detector])
    config["grid"] = copy.deepcopy(grid)
    if initial_spacing is not None:
        config["initial_spacing"] = initial_spacing
    return config
