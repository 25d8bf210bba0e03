"""The detectors the studies compare, by the keys of the report (studies.report.headline).

Every detector but the library baseline runs inside ``pfm-mpm`` (a ``detection`` block in the
case, or ``pfm-mpm detect`` on a particle file) with the configuration below: the defaults of
mpm/detect/detector.hpp, i.e. the thesis's final PFM configuration without smoothing
(``pfm``) and the improved detector (``improved``). The library baseline (scikit-image,
``studies/detectors/skimage_detector.py``) only post-processes particle files: its "total"
boundary is computed on the particles of the MPM run that used the improved detector.
"""

from __future__ import annotations

import copy
from typing import Optional

from studies.report.headline import DETECTORS

LIBRARY = "library"
METHODS = {
    "pfm_thesis": {"method": "pfm"},
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
