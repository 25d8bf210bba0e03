"""Surface loads of a case as exact consistent nodal forces on the mesh boundary.

The rule is the one of the C++ codes (the MPM's detected-boundary loads and the UL-FEM,
fem_reference/ulfem/ulfem_solver.cpp, apply_loads), applied to the exact finite element boundary:

* traction per current length on a boundary facet a -> b (material on the left, outward normal
  n = (d_y, -d_x) / L, d = b - a): vertical_pressure t = (0, -q n_y) (vertical only),
  follower_pressure t = -p n, traction t = (tx, ty);
* faces "upward" and "top" keep the facets with n_y > 0; "top" also drops the parts with
  boundary above them: each facet is cut at the x of every boundary vertex and a piece is
  loaded when no other boundary facet crosses the vertical line above its midpoint (the upper
  envelope); "all" keeps every facet;
* x_range: only the part x0 <= x <= x1 is loaded, clipped exactly inside the facet. Interval
  "fixed": x of the current facet; "material": x of the facet in the initial configuration, so
  the ends move with the material (with the displacement of the boundary at the ends). In small
  strain the two are the same (the mesh never moves).

The facets are straight (affine or bilinear geometry), so the displacement basis functions
restricted to a facet are the 1D Lagrange polynomials of its nodes (P1/Q1: the two vertices;
P2/Q2: the vertices and the mid-side node) in the facet parameter s; the traction is constant
along a facet, so integrating them over the loaded part [s0, s1] by their antiderivatives is
exact. Resultant of a load = sum of the nodal forces, to round-off.
"""
from __future__ import annotations

import numpy as np


def _weights(degree, p0, p1):
    """Integrals over [p0, p1] of the facet basis functions (a, b[, mid]) in s in [0, 1]."""

    def antiderivatives(s):
        if degree == 1:
            return [s - 0.5 * s * s, 0.5 * s * s]
        s2, s3 = s * s, s * s * s
        return [
            s - 1.5 * s2 + (2.0 / 3.0) * s3,  # (1 - s)(1 - 2s)
            (2.0 / 3.0) * s3 - 0.5 * s2,  # s(2s - 1)
            2.0 * s2 - (4.0 / 3.0) * s3,
        ]  # 4s(1 - s)

    return [hi - lo for lo, hi in zip(antiderivatives(p0), antiderivatives(p1))]


class SurfaceLoads:
    """Nodal force vectors (blocked dof numbering, kN/m) of the case loads at full magnitude.

    facets: (n, 2) vertex-geometry node indices a, b (material on the left of a -> b);
    dofs: (n, 2 or 3) displacement dofs of a, b and (degree 2) the mid-side node;
    reference: (n_nodes, 2) initial geometry node coordinates."""

    def __init__(self, loads, facets, dofs, reference, degree, cell_size):
        self.loads = loads
        self.facets = np.asarray(facets, dtype=np.int64).reshape(-1, 2)
        self.dofs = np.asarray(dofs, dtype=np.int64).reshape(len(self.facets), -1)
        self.reference = np.asarray(reference, dtype=float)[:, :2].copy()
        self.degree = 1 if self.dofs.shape[1] == 2 else 2
        assert degree in (1, 2) and self.degree == degree
        self.tol = 1e-9 * cell_size
        self._cache = {}

    def vector(self, k, positions, n_dofs, version):
        """Nodal forces of load k (full magnitude) on the geometry `positions` (current node
        coordinates); cached per geometry version."""
        key = (k, version)
        if key not in self._cache:
            self._cache = {kk: v for kk, v in self._cache.items() if kk[1] == version}
            self._cache[key] = self._assemble(self.loads[k], positions[:, :2], n_dofs)
        return self._cache[key]

    # ---------------------------------------------------------------------------------------
    def _assemble(self, load, x, n_dofs):
        a, b = x[self.facets[:, 0]], x[self.facets[:, 1]]
        d = b - a
        length = np.linalg.norm(d, axis=1)
        keep = length > 0.0
        if load.faces != "all":
            keep &= -d[:, 0] > 1e-12 * length  # outward n_y > 0
        s0 = np.zeros(len(d))
        s1 = np.ones(len(d))
        if load.x_range is not None:
            x0, x1 = load.x_range
            if load.interval == "material":
                ax = self.reference[self.facets[:, 0], 0]
                dx = self.reference[self.facets[:, 1], 0] - ax
            else:
                ax, dx = a[:, 0], d[:, 0]
            slanted = dx != 0.0
            safe = np.where(slanted, dx, 1.0)
            t0, t1 = (x0 - ax) / safe, (x1 - ax) / safe
            s0 = np.where(slanted, np.maximum(0.0, np.minimum(t0, t1)), 0.0)
            s1 = np.where(slanted, np.minimum(1.0, np.maximum(t0, t1)), 1.0)
            keep &= slanted | ((ax >= x0) & (ax <= x1))
        keep &= s1 > s0
        # force per unit of the facet parameter s: t L
        if load.type == "vertical_pressure":
            per_unit = np.stack([np.zeros(len(d)), load.pressure * d[:, 0]], axis=1)
        elif load.type == "follower_pressure":
            per_unit = -load.pressure * np.stack([d[:, 1], -d[:, 0]], axis=1)
        else:
            per_unit = np.outer(length, load.traction)
        pieces = []  # (facet, p0, p1)
        if load.faces == "top":
            pieces = self._top_pieces(x, a, d, np.nonzero(keep)[0], s0, s1)
        else:
            pieces = [(f, s0[f], s1[f]) for f in np.nonzero(keep)[0]]
        force = np.zeros(n_dofs)
        for f, p0, p1 in pieces:
            for dof, w in zip(self.dofs[f], _weights(self.degree, p0, p1)):
                force[2 * dof : 2 * dof + 2] += w * per_unit[f]
        return force

    def _top_pieces(self, x, a, d, candidates, s0, s1):
        """Split the candidate (upward) facets at the boundary vertices' x and keep the pieces
        with no boundary facet above their midpoint."""
        boundary_x = np.unique(x[self.facets[:, 0], 0])
        all_a, all_b = x[self.facets[:, 0]], x[self.facets[:, 1]]
        pieces, mids = [], []
        for f in candidates:
            xa = a[f, 0] + s0[f] * d[f, 0]
            xb = a[f, 0] + s1[f] * d[f, 0]  # d_x < 0: xb < xa
            lo, hi = np.searchsorted(boundary_x, [xb, xa], side="right")
            cuts = [
                (c - a[f, 0]) / d[f, 0] for c in boundary_x[lo:hi][::-1] if xb < c < xa
            ]
            ends = [s0[f], *cuts, s1[f]]
            for p0, p1 in zip(ends[:-1], ends[1:]):
                if p1 > p0:
                    pieces.append((f, p0, p1))
                    mids.append(a[f] + 0.5 * (p0 + p1) * d[f])
        if not pieces:
            return []
        mids = np.asarray(mids)
        px, py = mids[:, :1], mids[:, 1:]
        crosses = (px - all_a[:, 0]) * (px - all_b[:, 0]) < 0.0
        dxs = all_b[:, 0] - all_a[:, 0]
        safe = np.where(dxs != 0.0, dxs, 1.0)
        y_edge = all_a[:, 1] + (px - all_a[:, 0]) / safe * (all_b[:, 1] - all_a[:, 1])
        shadowed = np.any(crosses & (y_edge > py + self.tol), axis=1)
        return [piece for piece, dark in zip(pieces, shadowed) if not dark]
