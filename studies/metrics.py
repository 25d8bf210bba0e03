"""Distances between boundaries (polylines), overall and per region.

Loop CSV format (what the detectors and the FEM write): columns ``loop,x,y`` and optionally
``closed`` (1/0, default 1). Points of one loop are consecutive rows with the same ``loop``
id. Material lies on the left when walking along a loop (outer loops counter-clockwise, holes
clockwise); a closed loop does not repeat its first point.

Measures between a detected boundary A and a reference boundary B (both sets of loops):

* directed distance d(a, B) = min over the segments of B of the exact point-to-segment distance;
* **mean** = (integral over A of d(a, B) ds + integral over B of d(b, A) ds) / (|A| + |B|),
  a symmetric, arc-length weighted mean;
* **RMS**  = the same with d squared, then the square root;
* **max**  = the symmetric Hausdorff distance max(sup_A d(a, B), sup_B d(b, A)).

The integrals and suprema are taken over a dense resampling of each polyline: every original
vertex is kept and each segment is cut into pieces no longer than ``spacing`` (default h / 20,
or total length / 2000 without h); integrals use the trapezoid rule on those samples. The
distances at the samples are exact, so the mean and RMS are exact whenever d varies linearly
along each piece (parallel or coincident segments), and because d is 1-Lipschitz the sampled
max is below the true Hausdorff distance by at most ``spacing / 2`` (reported as
``max_resolution``).

Regions. A region is a named predicate on points (a box, a disk, a band around a segment...).
Regions are defined on the **reference** boundary and tried in order; the first that holds
names the point, a point no region holds is in ``other``. A reference sample is assigned by its
own position; a detected sample by the position of its closest point on the reference, so both
directions of the distance are split the same way. The factories ``slope_regions`` and
``block_regions`` give the regions of the two study geometries (see their docstrings).
All lengths in metres; ``in_h`` divides by the cell size h.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, Optional, Sequence

import numpy as np
import pandas as pd

OTHER = "other"
_CHUNK = 2_000_000  # point-segment pairs per vectorised block


@dataclass
class Polyline:
    points: np.ndarray  # (n, 2), m
    closed: bool = True

    def __post_init__(self):
        self.points = np.asarray(self.points, dtype=float).reshape(-1, 2)

    def segments(self) -> tuple[np.ndarray, np.ndarray]:
        """(starts, ends), each (s, 2); a closed loop includes the segment back to the start."""
        p = self.points
        if len(p) < 2:
            return p[:0], p[:0]
        if self.closed:
            return p, np.roll(p, -1, axis=0)
        return p[:-1], p[1:]

    def length(self) -> float:
        a, b = self.segments()
        return float(np.sum(np.hypot(*(b - a).T)))

    def drawn(self) -> np.ndarray:
        """The points to draw: a closed loop repeats its first point at the end."""
        if self.closed and len(self.points):
            return np.vstack([self.points, self.points[:1]])
        return self.points


def read_loops(path: Path) -> list[Polyline]:
    frame = pd.read_csv(path)
    missing = {"loop", "x", "y"} - set(frame.columns)
    if missing:
        raise ValueError(
            f"{path}: loop CSV needs columns loop,x,y; missing {sorted(missing)}"
        )
    loops = []
    for _, group in frame.groupby("loop", sort=False):
        closed = bool(group["closed"].iloc[0]) if "closed" in group else True
        loops.append(Polyline(group[["x", "y"]].to_numpy(), closed))
    return loops


def write_loops(path: Path, loops: Sequence[Polyline]) -> None:
    rows = [
        (i, x, y, int(loop.closed))
        for i, loop in enumerate(loops)
        for x, y in loop.points
    ]
    pd.DataFrame(rows, columns=["loop", "x", "y", "closed"]).to_csv(
        path, index=False, float_format="%.17g"
    )


def resample(
    loops: Sequence[Polyline], spacing: float
) -> tuple[np.ndarray, np.ndarray]:
    """Samples (m, 2) and trapezoid weights (m,) whose sum is the total length.

    Each segment is cut into n = ceil(length / spacing) equal pieces and sampled at its n + 1
    piece ends with weights (p/2, p, ..., p, p/2); a vertex shared by two segments appears once
    per segment, each time with half a piece of weight.
    """
    all_points, all_weights = [], []
    for loop in loops:
        a, b = loop.segments()
        if len(a) == 0:
            continue
        lengths = np.hypot(*(b - a).T)
        pieces = np.maximum(1, np.ceil(lengths / spacing).astype(int))
        for start, end, length, n in zip(a, b, lengths, pieces):
            t = np.arange(n + 1)[:, None] / n
            all_points.append(start + t * (end - start))
            w = np.full(n + 1, length / n)
            w[0] = w[-1] = 0.5 * length / n
            all_weights.append(w)
    if not all_points:
        return np.empty((0, 2)), np.empty(0)
    return np.concatenate(all_points), np.concatenate(all_weights)


def closest_on_segments(
    points: np.ndarray, starts: np.ndarray, ends: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Exact distance from each point to the nearest segment, and that nearest point."""
    if len(starts) == 0:
        raise ValueError("distance to an empty boundary")
    direction = ends - starts
    length2 = np.einsum("ij,ij->i", direction, direction)
    safe = np.where(length2 > 0.0, length2, 1.0)
    distances = np.empty(len(points))
    nearest = np.empty((len(points), 2))
    block = max(1, _CHUNK // len(starts))
    for first in range(0, len(points), block):
        p = points[first : first + block, None, :]  # (m, 1, 2)
        t = np.einsum("msk,sk->ms", p - starts[None], direction) / safe
        t = np.clip(np.where(length2 > 0.0, t, 0.0), 0.0, 1.0)
        foot = starts[None] + t[..., None] * direction[None]  # (m, s, 2)
        d2 = np.sum((p - foot) ** 2, axis=2)
        best = np.argmin(d2, axis=1)
        rows = np.arange(len(best))
        distances[first : first + block] = np.sqrt(d2[rows, best])
        nearest[first : first + block] = foot[rows, best]
    return distances, nearest


def _all_segments(loops: Sequence[Polyline]) -> tuple[np.ndarray, np.ndarray]:
    parts = [loop.segments() for loop in loops]
    return (
        np.concatenate([p[0] for p in parts]),
        np.concatenate([p[1] for p in parts]),
    )


@dataclass
class DistanceStats:
    mean: Optional[float]
    rms: Optional[float]
    max: Optional[float]
    length_detected: float  # m of detected boundary in the region
    length_reference: float  # m of reference boundary in the region
    max_resolution: float  # m, bound on how much the sampled max may miss

    def scaled(self, h: float) -> "DistanceStats":
        f = lambda v: None if v is None else v / h
        return DistanceStats(
            f(self.mean),
            f(self.rms),
            f(self.max),
            self.length_detected,
            self.length_reference,
            self.max_resolution / h,
        )


def _stats(d_a, w_a, d_b, w_b, resolution) -> DistanceStats:
    total = w_a.sum() + w_b.sum()
    if total <= 0.0:
        return DistanceStats(None, None, None, 0.0, 0.0, resolution)
    mean = (np.dot(d_a, w_a) + np.dot(d_b, w_b)) / total
    rms = np.sqrt((np.dot(d_a**2, w_a) + np.dot(d_b**2, w_b)) / total)
    largest = max(d_a.max(initial=0.0), d_b.max(initial=0.0))
    return DistanceStats(
        float(mean),
        float(rms),
        float(largest),
        float(w_a.sum()),
        float(w_b.sum()),
        resolution,
    )


@dataclass
class Region:
    name: str
    contains: Callable[[np.ndarray], np.ndarray]  # (m, 2) points -> (m,) bool
    description: str = ""


def box_region(name: str, lower, upper, description: str = "") -> Region:
    (x0, y0), (x1, y1) = lower, upper
    return Region(
        name,
        lambda p: (p[:, 0] >= x0) & (p[:, 0] <= x1) & (p[:, 1] >= y0) & (p[:, 1] <= y1),
        description or f"box [{x0}, {x1}] x [{y0}, {y1}]",
    )


def disk_region(name: str, centre, radius: float, description: str = "") -> Region:
    cx, cy = centre
    return Region(
        name,
        lambda p: np.hypot(p[:, 0] - cx, p[:, 1] - cy) <= radius,
        description or f"disk centre ({cx}, {cy}) radius {radius}",
    )


def band_region(
    name: str, start, end, half_width: float, description: str = ""
) -> Region:
    a, b = np.asarray(start, float), np.asarray(end, float)

    def contains(p):
        d, _ = closest_on_segments(p, a[None], b[None])
        return d <= half_width

    return Region(
        name, contains, description or f"within {half_width} of {tuple(a)}-{tuple(b)}"
    )


def assign_regions(points: np.ndarray, regions: Sequence[Region]) -> np.ndarray:
    """Region name of each point (first region that contains it, else ``other``)."""
    labels = np.full(len(points), OTHER, dtype=object)
    free = np.ones(len(points), dtype=bool)
    for region in regions:
        if not free.any():
            break
        hit = np.zeros(len(points), dtype=bool)
        hit[free] = np.asarray(region.contains(points[free]), dtype=bool)
        labels[hit] = region.name
        free &= ~hit
    return labels


def slope_regions(
    crest,
    toe,
    radius: float = 1.0,
    band: Optional[float] = None,
    load_range: Optional[Sequence[float]] = None,
) -> list[Region]:
    """Regions of a slope, from its crest and toe corners (m) on the reference boundary.

    In order of precedence:
    ``loaded_strip``  within ``band`` of the crest level and x inside ``load_range`` (if given);
    ``crest``         disk of radius ``radius`` around the crest corner;
    ``toe``           disk of radius ``radius`` around the toe corner;
    ``face``          within ``band`` of the segment crest-toe;
    ``top``           within ``band`` of the crest level, on the crest's side (behind the crest);
    ``bottom``        within ``band`` of the toe level, in front of the toe (the thesis's
                      "bottom of the slope", 5.5.2);
    ``other``         the rest (fixed base and sides, unless left out with ``ignore``).
    ``band`` defaults to ``radius``; the default radius 1 m is 2 h at the thesis's h = 0.5 m.
    """
    band = radius if band is None else band
    (xc, yc), (xt, yt) = crest, toe
    side = 1.0 if xt >= xc else -1.0  # +1: the slope descends towards +x
    regions = []
    if load_range is not None:
        x0, x1 = load_range
        regions.append(
            Region(
                "loaded_strip",
                lambda p: (np.abs(p[:, 1] - yc) <= band)
                & (p[:, 0] >= x0)
                & (p[:, 0] <= x1),
                f"|y - {yc}| <= {band}, x in [{x0}, {x1}]",
            )
        )
    regions += [
        disk_region("crest", crest, radius),
        disk_region("toe", toe, radius),
        band_region("face", crest, toe, band),
        Region(
            "top",
            lambda p: (np.abs(p[:, 1] - yc) <= band) & ((p[:, 0] - xc) * side <= 0),
            f"|y - {yc}| <= {band}, behind the crest",
        ),
        Region(
            "bottom",
            lambda p: (np.abs(p[:, 1] - yt) <= band) & ((p[:, 0] - xt) * side >= 0),
            f"|y - {yt}| <= {band}, in front of the toe",
        ),
    ]
    return regions


def block_regions(
    top_y: float, load_range: Sequence[float], band: float = 1.0
) -> list[Region]:
    """Regions of the bearing block: ``loaded_strip`` (within ``band`` of the top level, x in
    the loaded range), ``top`` (the rest of the top surface), ``other`` (fixed base, sides).
    """
    x0, x1 = load_range
    return [
        Region(
            "loaded_strip",
            lambda p: (np.abs(p[:, 1] - top_y) <= band)
            & (p[:, 0] >= x0)
            & (p[:, 0] <= x1),
            f"|y - {top_y}| <= {band}, x in [{x0}, {x1}]",
        ),
        Region(
            "top", lambda p: np.abs(p[:, 1] - top_y) <= band, f"|y - {top_y}| <= {band}"
        ),
    ]


@dataclass
class BoundaryDistance:
    overall: DistanceStats
    regions: dict = field(default_factory=dict)  # name -> DistanceStats
    h: Optional[float] = None
    spacing: float = 0.0

    def rows(self) -> list[dict]:
        """One row per region (``all`` first): metres and, when h is known, units of h."""
        out = []
        for name, stats in [("all", self.overall), *self.regions.items()]:
            row = {
                "region": name,
                "mean_m": stats.mean,
                "rms_m": stats.rms,
                "max_m": stats.max,
            }
            if self.h:
                s = stats.scaled(self.h)
                row.update({"mean_h": s.mean, "rms_h": s.rms, "max_h": s.max})
            row.update(
                {
                    "length_detected_m": stats.length_detected,
                    "length_reference_m": stats.length_reference,
                    "max_resolution_m": stats.max_resolution,
                }
            )
            out.append(row)
        return out


def grid_edge_band(grid: dict, band: float) -> Region:
    """The points within ``band`` (m) of the edges of a case's grid (``origin``, ``cell_size``,
    ``n_cells``): where a body rests on the grid edge (fixed base, roller sides) its boundary
    is the grid line, and detectors cannot see past the field grid there."""
    (x0, y0), h = grid.get("origin", (0.0, 0.0)), grid["cell_size"]
    x1, y1 = x0 + grid["n_cells"][0] * h, y0 + grid["n_cells"][1] * h
    return Region(
        "grid_edge_band",
        lambda p: (p[:, 0] <= x0 + band)
        | (p[:, 0] >= x1 - band)
        | (p[:, 1] <= y0 + band)
        | (p[:, 1] >= y1 - band),
        f"within {band} m of the grid edges",
    )


def supported_sides_band(rectangle, band: float) -> Region:
    """The points within ``band`` (m) of the left, right and bottom sides of a block
    ``rectangle`` [[x0, y0], [x1, y1]]: where walls and a base hold a block that does not rest
    on the grid edge (a grid with a margin, as uGIMP needs), the same part of the boundary that
    grid_edge_band leaves out when it does: not the free surface, and the detectors round the
    corners there."""
    (x0, y0), (x1, _) = rectangle
    return Region(
        "supported_sides_band",
        lambda p: (p[:, 0] <= x0 + band)
        | (p[:, 0] >= x1 - band)
        | (p[:, 1] <= y0 + band),
        f"within {band} m of the block's sides and base",
    )


def boundary_distance(
    detected: Sequence[Polyline],
    reference: Sequence[Polyline],
    h: Optional[float] = None,
    spacing: Optional[float] = None,
    regions: Sequence[Region] = (),
    ignore: Optional[Region] = None,
) -> BoundaryDistance:
    """Mean, RMS and max (Hausdorff) distance between two boundaries, overall and per region.

    ``ignore``: samples of either boundary inside this region are left out of every statistic
    (their distances are not counted); the distances of the other samples are still measured
    to the whole other boundary (the lengths kept are exact to one sample spacing). Used to leave out the parts of the boundary on the grid edges
    (grid_edge_band), which the reference has and a detector does not."""
    detected, reference = list(detected), list(reference)
    if spacing is None:
        total = sum(p.length() for p in detected + reference)
        spacing = h / 20.0 if h else max(total, 1e-12) / 2000.0
    a_points, a_weights = resample(detected, spacing)
    b_points, b_weights = resample(reference, spacing)
    d_a, foot_a = closest_on_segments(a_points, *_all_segments(reference))
    d_b, _ = closest_on_segments(b_points, *_all_segments(detected))
    if ignore is not None:
        keep_a = ~np.asarray(ignore.contains(a_points), dtype=bool)
        keep_b = ~np.asarray(ignore.contains(b_points), dtype=bool)
        a_points, a_weights, d_a, foot_a = (
            a_points[keep_a],
            a_weights[keep_a],
            d_a[keep_a],
            foot_a[keep_a],
        )
        b_points, b_weights, d_b = b_points[keep_b], b_weights[keep_b], d_b[keep_b]
    result = BoundaryDistance(
        _stats(d_a, a_weights, d_b, b_weights, spacing / 2), h=h, spacing=spacing
    )
    if regions:
        label_a = assign_regions(foot_a, regions)  # by the closest reference point
        label_b = assign_regions(b_points, regions)
        for name in [r.name for r in regions] + [OTHER]:
            in_a, in_b = label_a == name, label_b == name
            if in_a.any() or in_b.any():
                result.regions[name] = _stats(
                    d_a[in_a], a_weights[in_a], d_b[in_b], b_weights[in_b], spacing / 2
                )
    return result
