"""gmsh meshes of the case bodies (straight-sided triangles, or quadrilaterals)."""
from __future__ import annotations

import numpy as np


def _split_polygon(polygon, split_x, tol):
    """Insert vertices where an upward-facing edge (material below) crosses x = split_x."""
    out = []
    n = len(polygon)
    for i in range(n):
        a, b = np.array(polygon[i]), np.array(polygon[(i + 1) % n])
        out.append(tuple(a))
        # CCW polygon: outward normal of edge a->b is (dy, -dx); the edge faces up if -dx > 0
        if b[0] >= a[0] - tol:
            continue
        cuts = sorted((x for x in split_x if b[0] + tol < x < a[0] - tol), reverse=True)
        for x in cuts:
            t = (x - a[0]) / (b[0] - a[0])
            out.append((float(x), float(a[1] + t * (b[1] - a[1]))))
    return out


def surface_height(polygons, x):
    """Highest y of the bodies' boundaries on the vertical line through each x (local surface)."""
    x = np.asarray(x, dtype=float)
    top = np.full(x.shape, -np.inf)
    for poly in polygons:
        p = np.asarray(poly, dtype=float)
        a, b = p, np.roll(p, -1, axis=0)
        for (xa, ya), (xb, yb) in zip(a, b):
            lo, hi = min(xa, xb), max(xa, xb)
            inside = (x >= lo - 1e-12) & (x <= hi + 1e-12)
            if not np.any(inside):
                continue
            if abs(xb - xa) < 1e-14:
                y = np.full(x.shape, max(ya, yb))
            else:
                y = ya + (x - xa) / (xb - xa) * (yb - ya)
            top = np.where(inside, np.maximum(top, y), top)
    return top


def build_mesh(
    case,
    element_size=None,
    refine_size=None,
    refine_distance=None,
    quads=False,
    extra_split_x=(),
    verbose=False,
):
    """Mesh the case bodies with gmsh and convert to dolfinx.

    element_size: target size (default: the grid cell size). refine_size / refine_distance: a
    finer size near the loaded intervals (gmsh Distance + Threshold fields), off by default.
    extra_split_x: x coordinates where top edges get a vertex (load ends and centres always do).
    Returns (mesh, cell_tags (body index + 1), polygons used)."""
    import gmsh
    from mpi4py import MPI
    from dolfinx.io import gmshio

    h = element_size or case.cell_size
    tol = 1e-9 * max(1.0, case.cell_size)
    split = list(extra_split_x)
    for load in case.loads:
        if load.x_range is not None:
            x0, x1 = load.x_range
            split += [x0, x1, 0.5 * (x0 + x1)]
    unique = []
    for x in sorted(split):
        if not unique or x - unique[-1] > tol:  # several loads may share an end
            unique.append(x)
    polygons = [_split_polygon(body.polygon, unique, tol) for body in case.bodies]

    gmsh.initialize()
    gmsh.option.setNumber("General.Terminal", 1 if verbose else 0)
    gmsh.model.add("case")
    occ = gmsh.model.occ
    surfaces = []
    for poly in polygons:
        pts = [occ.addPoint(x, y, 0.0) for x, y in poly]
        lines = [occ.addLine(pts[i], pts[(i + 1) % len(pts)]) for i in range(len(pts))]
        loop = occ.addCurveLoop(lines)
        surfaces.append(occ.addPlaneSurface([loop]))
    if len(surfaces) > 1:
        _, mapping = occ.fragment([(2, s) for s in surfaces], [])
        body_surfaces = [[tag for dim, tag in m if dim == 2] for m in mapping]
    else:
        body_surfaces = [[surfaces[0]]]
    occ.synchronize()
    claimed = set()
    for k, tags in enumerate(body_surfaces):
        tags = [
            t for t in tags if t not in claimed
        ]  # overlaps belong to the first body
        claimed.update(tags)
        gmsh.model.addPhysicalGroup(2, tags, k + 1)
    gmsh.option.setNumber("Mesh.CharacteristicLengthMax", h)
    gmsh.option.setNumber("Mesh.CharacteristicLengthMin", min(h, refine_size or h))
    if refine_size is not None:
        load_pts = []
        for load in case.loads:
            if load.x_range is None:
                continue
            x0, x1 = load.x_range
            ys = surface_height(polygons, [x0, x1])
            for x, y in zip((x0, x1), ys):
                load_pts.append(occ.addPoint(x, y, 0.0))
        occ.synchronize()
        fd = gmsh.model.mesh.field.add("Distance")
        gmsh.model.mesh.field.setNumbers(fd, "PointsList", load_pts)
        ft = gmsh.model.mesh.field.add("Threshold")
        gmsh.model.mesh.field.setNumber(ft, "InField", fd)
        gmsh.model.mesh.field.setNumber(ft, "SizeMin", refine_size)
        gmsh.model.mesh.field.setNumber(ft, "SizeMax", h)
        dist = refine_distance or 2.0 * h
        gmsh.model.mesh.field.setNumber(ft, "DistMin", 0.5 * dist)
        gmsh.model.mesh.field.setNumber(ft, "DistMax", dist)
        gmsh.model.mesh.field.setAsBackgroundMesh(ft)
        gmsh.option.setNumber("Mesh.MeshSizeExtendFromBoundary", 0)
        gmsh.option.setNumber("Mesh.MeshSizeFromPoints", 0)
    if quads:
        gmsh.option.setNumber("Mesh.RecombineAll", 1)
        # 8 (quad Delaunay) segfaults in gmsh 4.8
        gmsh.option.setNumber("Mesh.Algorithm", 6)
    gmsh.model.mesh.generate(2)
    if quads and 2 in gmsh.model.mesh.getElementTypes(2):
        # triangles left over: split everything into quadrilaterals at half the size
        gmsh.model.mesh.clear()
        for name in ("Mesh.CharacteristicLengthMax", "Mesh.CharacteristicLengthMin"):
            gmsh.option.setNumber(name, 2.0 * gmsh.option.getNumber(name))
        gmsh.option.setNumber("Mesh.SubdivisionAlgorithm", 1)
        gmsh.model.mesh.generate(2)
    mesh, cell_tags, _ = gmshio.model_to_mesh(gmsh.model, MPI.COMM_WORLD, 0, gdim=2)
    gmsh.finalize()
    return mesh, cell_tags, polygons
