"""Plane-strain finite element model of a case: P2 (or P1) displacement, quadrature-point state.

The state (stress rows sxx, syy, sxy, szz and the softening variable kappa) lives at the
quadrature points of every cell, in numpy arrays of shape (n_cells * n_qp, ...) in cell order;
dolfinx quadrature functions carry the stress and the 3x3 tangent into the forms.
"""
from __future__ import annotations

import numpy as np
import ufl
import basix
from mpi4py import MPI
from petsc4py import PETSc
import dolfinx
import dolfinx.fem.petsc  # noqa: F401 (registers fem.petsc)
from dolfinx import fem, mesh as dmesh

from .geometry import build_mesh, surface_height
from .loads import SurfaceLoads
from .material import ElasticPlasticModel


class NoConvergence(RuntimeError):
    pass


def _eps_v(w):
    e = ufl.sym(ufl.grad(w))
    return ufl.as_vector([e[0, 0], e[1, 1], 2.0 * e[0, 1]])


class Model:
    """Finite element model of a case (static Newton and explicit dynamics share it)."""

    def __init__(
        self,
        case,
        degree=2,
        element_size=None,
        refine_size=None,
        refine_distance=None,
        quads=False,
        updated_lagrangian=False,
        kappa_measure="plastic_shear",
        extra_split_x=(),
    ):
        self.case = case
        self.degree = degree
        self.updated_lagrangian = updated_lagrangian
        self.mesh, self.cell_tags, self.polygons = build_mesh(
            case, element_size, refine_size, refine_distance, quads, extra_split_x
        )
        msh = self.mesh
        tdim = msh.topology.dim
        msh.topology.create_connectivity(tdim - 1, tdim)
        self.n_cells = msh.topology.index_map(tdim).size_local
        cell = msh.ufl_cell()
        self.V = fem.VectorFunctionSpace(msh, ("CG", degree))
        self.qdeg = 2 * (degree - 1) if degree > 1 else 1
        if quads:
            self.qdeg = 2 * degree
        basix_cell = basix.CellType.quadrilateral if quads else basix.CellType.triangle
        self.qpoints, self.qweights = basix.make_quadrature(basix_cell, self.qdeg)
        self.nq = len(self.qweights)
        qe4 = ufl.VectorElement(
            "Quadrature", cell, self.qdeg, dim=4, quad_scheme="default"
        )
        qe9 = ufl.VectorElement(
            "Quadrature", cell, self.qdeg, dim=9, quad_scheme="default"
        )
        self.Q4 = fem.FunctionSpace(msh, qe4)
        self.Q9 = fem.FunctionSpace(msh, qe9)
        self.qdofs = self.Q4.dofmap.list.array.reshape(self.n_cells, self.nq).ravel()
        self.dx = ufl.Measure(
            "dx",
            domain=msh,
            metadata={"quadrature_degree": self.qdeg, "quadrature_scheme": "default"},
        )
        # materials per quadrature point
        body_of_cell = np.zeros(self.n_cells, dtype=np.int32)
        body_of_cell[self.cell_tags.indices] = self.cell_tags.values - 1
        # A softening length scales the cohesion laws by itself / the element size (the
        # target size of the mesh, as the MPM's cell size for its grid).
        self._material_size = element_size or case.cell_size
        self._kappa_measure = kappa_measure
        self.set_strength_factor(1.0)
        self.point_body = np.repeat(body_of_cell, self.nq)
        self.groups = [
            np.nonzero(self.point_body == k)[0] for k in range(len(self.models))
        ]
        gamma = np.array([m.material.unit_weight for m in self.models])
        dg0 = fem.FunctionSpace(msh, ("DG", 0))
        # DG0 dof of each cell
        self.dg0_dofs = dg0.dofmap.list.array.reshape(self.n_cells)
        self.rho = fem.Function(dg0)
        g = case.g if case.g > 0 else 9.81
        # t/m^3 (unit weight / g)
        self.rho.x.array[self.dg0_dofs] = gamma[body_of_cell] / g
        self.unit_weight = fem.Function(dg0)
        self.unit_weight0 = (
            gamma[body_of_cell] if case.g > 0 else 0.0 * gamma[body_of_cell]
        )
        self.unit_weight.x.array[self.dg0_dofs] = self.unit_weight0
        self.area0 = self.cell_areas()

        # state
        npts = self.n_cells * self.nq
        self.stress = np.zeros((npts, 4))
        self.kappa = np.zeros(npts)
        self.u = fem.Function(self.V, name="displacement")
        self.du = fem.Function(self.V)  # increment of the current step
        self.sig_q = fem.Function(self.Q4)
        self.tan_q = fem.Function(self.Q9)
        self.gravity_factor = fem.Constant(msh, PETSc.ScalarType(0.0))
        # load k acts with load_factor x load_fractions[k] x its magnitude (static: the common
        # load factor; explicit: load_factor 1 and each load's time function)
        self.load_factor = 0.0
        self.load_fractions = np.ones(len(case.loads))
        self.geometry_version = 0  # incremented whenever the mesh moves (UL)

        # expressions evaluated at the quadrature points
        self.grad_expr = fem.Expression(
            ufl.as_vector(
                [self.du[0].dx(0), self.du[0].dx(1), self.du[1].dx(0), self.du[1].dx(1)]
            ),
            self.qpoints,
        )
        self.x_expr = fem.Expression(ufl.SpatialCoordinate(msh), self.qpoints)
        self.cells = np.arange(self.n_cells, dtype=np.int32)

        self._setup_boundary()
        self._setup_forms()
        self._setup_tracking()
        self._setup_loads()

    def set_strength_factor(self, factor: float):
        """Every body's material with its strength divided by `factor` (Material.reduced);
        the stresses and the plastic strains are kept."""
        self.strength_factor = factor
        self.models = [
            ElasticPlasticModel(
                self.case.materials[b.material]
                .reduced(factor)
                .regularised(self._material_size),
                self._kappa_measure,
            )
            for b in self.case.bodies
        ]

    # ------------------------------------------------------------------ setup
    def _setup_boundary(self):
        case, msh = self.case, self.mesh
        fdim = msh.topology.dim - 1
        gx0, gy0, gx1, gy1 = case.grid_box
        tol = 1e-6 * case.cell_size
        lines = {
            "left": lambda x: np.isclose(x[0], gx0, atol=tol),
            "right": lambda x: np.isclose(x[0], gx1, atol=tol),
            "bottom": lambda x: np.isclose(x[1], gy0, atol=tol),
            "top": lambda x: np.isclose(x[1], gy1, atol=tol),
        }
        self.bcs = []
        self.fixed_dofs = []  # dof indices (into u.x.array) of each fixed component
        # per boundary condition: [(component, its dofs)]
        self.support_dofs = []
        for k, bc in enumerate(case.boundary_conditions):
            comps = {"x": [0], "y": [1], "xy": [0, 1]}[bc.fix]
            held = []
            for comp in comps:
                sub = self.V.sub(comp)
                if bc.where in lines:
                    facets = dmesh.locate_entities_boundary(msh, fdim, lines[bc.where])
                    dofs = fem.locate_dofs_topological(sub, fdim, facets)
                else:
                    collapsed, _ = sub.collapse()
                    inside = _node_set_test(case.node_sets[bc.where], tol)
                    dofs = fem.locate_dofs_geometrical((sub, collapsed), inside)[0]
                if len(dofs) == 0 and bc.velocity is not None:
                    # (a support off the body holds nothing, as on the MPM's empty nodes)
                    raise ValueError(
                        f"{case.file}: /boundary_conditions/{k}/where: "
                        f"'{bc.where}' holds no node of the mesh to move"
                    )
                self.bcs.append(fem.dirichletbc(PETSc.ScalarType(0.0), dofs, sub))
                self.fixed_dofs.append(dofs)
                held.append((comp, dofs))
            self.support_dofs.append(held)
        self.moving_supports = [
            k
            for k, bc in enumerate(case.boundary_conditions)
            if bc.velocity is not None
        ]
        # time of the committed state (s): the moving supports' displacements are theirs at it
        self.time = 0.0
        self.constrained = (
            np.unique(np.concatenate(self.fixed_dofs))
            if self.fixed_dofs
            else np.zeros(0, dtype=np.int32)
        )

        # exterior facets, oriented with the material on the left (the loads act on them)
        exterior = dmesh.exterior_facet_indices(msh.topology)
        f2v = msh.topology.connectivity(fdim, 0)
        f2c = msh.topology.connectivity(fdim, fdim + 1)
        c2v = msh.topology.connectivity(fdim + 1, 0)
        xg = msh.geometry.x
        # vertex -> geometry node (P1 geometry: per cell same local order)
        self.vertex_to_node = np.zeros(
            msh.topology.index_map(0).size_local, dtype=np.int64
        )
        gdm = msh.geometry.dofmap
        for c in range(self.n_cells):
            self.vertex_to_node[c2v.links(c)] = gdm.links(c)
        self.exterior_facets = []
        for f in exterior:
            va, vb = f2v.links(f)
            a, b = xg[self.vertex_to_node[va], :2], xg[self.vertex_to_node[vb], :2]
            c = f2c.links(f)[0]
            centroid = xg[self.vertex_to_node[c2v.links(c)], :2].mean(axis=0)
            # orient the facet with the material on the left: (b - a) x (centroid - a) > 0
            if (b[0] - a[0]) * (centroid[1] - a[1]) - (b[1] - a[1]) * (
                centroid[0] - a[0]
            ) < 0:
                va, vb = vb, va
            self.exterior_facets.append((va, vb))

    def _setup_forms(self):
        v = ufl.TestFunction(self.V)
        w = ufl.TrialFunction(self.V)
        sig = ufl.as_vector([self.sig_q[0], self.sig_q[1], self.sig_q[2]])
        C = ufl.as_matrix([[self.tan_q[3 * i + j] for j in range(3)] for i in range(3)])
        body = ufl.as_vector([0.0, -1.0]) * self.unit_weight * self.gravity_factor
        f_ext = ufl.inner(body, v) * self.dx
        # body force only: the surface loads are added as nodal force vectors (load_vector)
        self.f_ext_form = fem.form(f_ext)
        self.residual_form = fem.form(ufl.inner(sig, _eps_v(v)) * self.dx - f_ext)
        self.tangent_form = fem.form(
            ufl.inner(ufl.dot(C, _eps_v(w)), _eps_v(v)) * self.dx
        )
        self.A = fem.petsc.create_matrix(self.tangent_form)
        self.b = fem.petsc.create_vector(self.residual_form)
        self.ksp = PETSc.KSP().create(MPI.COMM_SELF)
        self.ksp.setOperators(self.A)
        self.ksp.setType("preonly")
        pc = self.ksp.getPC()
        pc.setType("lu")
        pc.setFactorSolverType("mumps")
        self.delta = self.A.createVecRight()

    def _setup_tracking(self):
        """Probe dofs: P2 vertex dofs found by coordinates (initial configuration)."""
        from scipy.spatial import cKDTree

        self.dof_coords0 = self.V.tabulate_dof_coordinates()[:, :2].copy()
        self.dof_tree = cKDTree(self.dof_coords0)
        self.probes = {}
        for k, load in enumerate(self.case.loads):
            if load.x_range is None:
                continue
            xc = 0.5 * (load.x_range[0] + load.x_range[1])
            yc = surface_height(self.polygons, [xc])[0]
            self.add_probe(f"load{k}_centre", (xc, yc))
        dist, self.node_dof = self.dof_tree.query(self.mesh.geometry.x[:, :2])
        assert dist.max() < 1e-9 * max(
            1.0, self.case.cell_size
        ), "geometry nodes must be dofs"
        self.vertex_dof = self.node_dof[self.vertex_to_node]

    def _setup_loads(self):
        """Exact consistent nodal forces of the case loads on the exterior facets (loads.py)."""
        vdof = self.vertex_dof
        rows = []
        for va, vb in self.exterior_facets:
            row = [vdof[va], vdof[vb]]
            if self.degree == 2:
                mid = 0.5 * (self.dof_coords0[vdof[va]] + self.dof_coords0[vdof[vb]])
                dist, dof = self.dof_tree.query(mid)
                assert dist < 1e-9 * max(
                    1.0, self.case.cell_size
                ), "mid-side node not found"
                row.append(dof)
            rows.append(row)
        facets = [
            (self.vertex_to_node[va], self.vertex_to_node[vb])
            for va, vb in self.exterior_facets
        ]
        self.surface_loads = SurfaceLoads(
            self.case.loads,
            facets,
            rows,
            self.mesh.geometry.x.copy(),
            self.degree,
            self.case.cell_size,
        )

    def load_vector(self, k=None, factor=None):
        """Nodal forces (numpy, blocked dofs, kN/m) of load k, or of all loads, times their
        factors (load_factor x load_fractions[k], unless `factor` is given), on the current
        geometry (UL: the configuration of the last converged increment)."""
        n = self.u.x.array.size
        total = np.zeros(n)
        for j in range(len(self.case.loads)) if k is None else [k]:
            scale = (
                factor
                if factor is not None
                else self.load_factor * self.load_fractions[j]
            )
            if scale != 0.0:
                total += scale * self.surface_loads.vector(
                    j, self.mesh.geometry.x, n, self.geometry_version
                )
        return total

    def add_probe(self, name, point):
        dist, dof = self.dof_tree.query(np.asarray(point, dtype=float))
        self.probes[name] = (int(dof), self.dof_coords0[dof].copy(), float(dist))

    def probe_displacement(self, name):
        return self.u.x.array.reshape(-1, 2)[self.probes[name][0]].copy()

    def quadrature_coordinates(self):
        return self.x_expr.eval(self.cells).reshape(-1, 2)

    # ------------------------------------------------------------------ state
    def _to_quadrature(self, func, values, width):
        arr = func.x.array.reshape(-1, width)
        arr[self.qdofs] = values.reshape(-1, width)
        func.x.scatter_forward()

    def _increment_gradient(self):
        return self.grad_expr.eval(self.cells).reshape(-1, 4)

    def _constitutive(self, grad):
        """Stress and tangent at the end of the increment self.du, from the committed state."""
        dstrain = np.stack([grad[:, 0], grad[:, 3], grad[:, 1] + grad[:, 2]], axis=1)
        base = self.stress
        if self.updated_lagrangian:
            base = self._jaumann(self.stress, grad)
        new_stress = np.empty_like(self.stress)
        new_kappa = np.empty_like(self.kappa)
        tangent = np.empty((self.stress.shape[0], 3, 3))
        for model, idx in zip(self.models, self.groups):
            s, k, t = model.update_with_tangent(
                base[idx], self.kappa[idx], dstrain[idx]
            )
            new_stress[idx], new_kappa[idx], tangent[idx] = s, k, t
        return new_stress, new_kappa, tangent

    @staticmethod
    def _jaumann(stress, grad):
        """Rotate the stress by the spin of the increment: s + W s - s W (W = skew(grad du))."""
        w = 0.5 * (grad[:, 1] - grad[:, 2])  # W_xy
        sxx, syy, sxy = stress[:, 0], stress[:, 1], stress[:, 2]
        out = stress.copy()
        out[:, 0] = sxx + 2.0 * w * sxy
        out[:, 1] = syy - 2.0 * w * sxy
        out[:, 2] = sxy + w * (syy - sxx)
        return out

    # ------------------------------------------------------------------ solve
    def _assemble_residual(self, supports=False):
        """f_int - f_ext at the stress in sig_q; zero on the fixed dofs unless `supports`
        (there it is the force the supports exert, the reaction)."""
        with self.b.localForm() as loc:
            loc.set(0.0)
        fem.petsc.assemble_vector(self.b, self.residual_form)
        self.b.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        if self.case.loads:
            self.b.array[:] -= self.load_vector()
        if not supports:
            fem.petsc.set_bc(self.b, self.bcs, scale=0.0)
        return self.b

    def reactions(self):
        """kN/m: the force (fx, fy) each boundary condition exerts on the body in the committed
        state, the sum of f_int - f_ext over its fixed dofs (a component it does not fix: 0).
        """
        self._to_quadrature(self.sig_q, self.stress, 4)
        residual = self._assemble_residual(supports=True).array
        out = []
        for held in self.support_dofs:
            force = [0.0, 0.0]
            for comp, dofs in held:
                force[comp] = float(np.sum(residual[dofs]))
            out.append(tuple(force))
        return out

    def _predict(self, time):
        """The first iterate of an increment that moves the supports to their displacement
        at `time`: du = d on their dofs (d: that displacement less the committed one) and, on
        the free dofs, the linear solution with the tangent of the committed state,
        K_ff du_f = -R_f(0) - K_fc d (a support's increment spread through the body instead
        of concentrated in the elements along it, which would yield there spuriously).
        """
        prescribed = np.zeros_like(self.du.x.array)
        for k in self.moving_supports:
            target = self.case.boundary_conditions[k].displacement(time)
            for comp, dofs in self.support_dofs[k]:
                prescribed[dofs] = target[comp] - self.u.x.array[dofs]
        self.du.x.array[:] = 0.0
        stress, _, tangent = self._constitutive(self._increment_gradient())
        self._to_quadrature(self.sig_q, stress, 4)
        self._to_quadrature(self.tan_q, tangent.reshape(-1, 9), 9)
        self.A.zeroEntries()
        fem.petsc.assemble_matrix(self.A, self.tangent_form)
        self.A.assemble()
        lift = self.A.createVecRight()
        lift.array[:] = prescribed
        coupling = self.A.createVecLeft()
        self.A.mult(lift, coupling)
        rhs = self._assemble_residual()
        rhs.array[:] += coupling.array
        rhs.array[self.constrained] = 0.0
        self._solve_tangent(rhs)
        self.du.x.array[:] = prescribed - self.delta.array
        self.du.x.scatter_forward()
        lift.destroy()
        coupling.destroy()

    def _solve_tangent(self, rhs):
        """delta = K^-1 rhs with the tangent in tan_q (fixed dofs: delta = rhs there)."""
        self.A.zeroEntries()
        fem.petsc.assemble_matrix(self.A, self.tangent_form, bcs=self.bcs)
        self.A.assemble()
        self.ksp.setOperators(self.A)
        self.ksp.solve(rhs, self.delta)

    def external_force(self):
        """External nodal forces (numpy, kN/m): body force and surface loads at the current
        factors, constrained dofs included."""
        vec = fem.petsc.assemble_vector(self.f_ext_form)
        vec.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        values = vec.array.copy()
        vec.destroy()
        if self.case.loads:
            values += self.load_vector()
        return values

    def external_force_norm(self):
        values = self.external_force()
        values[self.constrained] = 0.0
        return float(np.linalg.norm(values))

    def solve_step(
        self, gravity_factor, load_factor, rtol=1e-8, max_iterations=25, time=None
    ):
        """Newton for one increment to the given load factors and (with `time`, s) to the
        moving supports' displacements at that time; commits on success.

        The supports' increment is imposed at the first iterate (_predict; the corrections
        vanish on every fixed dof). Converged when ||R|| <= rtol ||f_ext|| (R on the free
        dofs), or with moving supports rtol max(||f_ext||, ||reactions||) (the reactions of
        the iterate). Gives up after max_iterations, or when the residual has not improved on
        its best value for 10 iterations or exceeds 1e6 times that reference. Returns the
        number of iterations; raises NoConvergence (state untouched)."""
        self.gravity_factor.value = gravity_factor
        self.load_factor = load_factor
        self.du.x.array[:] = 0.0
        if time is not None:
            self._predict(time)
        external = self.external_force_norm()
        driven = time is not None and bool(self.moving_supports)
        best, best_iteration = np.inf, 0
        for iteration in range(max_iterations + 1):
            stress, kappa, tangent = self._constitutive(self._increment_gradient())
            self._to_quadrature(self.sig_q, stress, 4)
            residual = self._assemble_residual(supports=driven)
            reference = external
            if driven:  # the reactions of the iterate, then R on the free dofs only
                reactions = residual.array[self.constrained]
                reference = max(reference, float(np.linalg.norm(reactions)))
                residual.array[self.constrained] = 0.0
            reference = max(reference, 1e-12)
            rnorm = residual.norm()
            if not np.isfinite(rnorm):
                break
            if rnorm <= rtol * reference:
                self._commit(stress, kappa)
                if time is not None:
                    self.time = time
                return iteration
            if rnorm < best:
                best, best_iteration = rnorm, iteration
            elif iteration - best_iteration >= 10 or rnorm > 1e6 * reference:
                break  # diverging or stalled: halving the increment is cheaper
            self._to_quadrature(self.tan_q, tangent.reshape(-1, 9), 9)
            self._solve_tangent(residual)
            self.du.x.array[:] -= self.delta.array
            self.du.x.scatter_forward()
        self.du.x.array[:] = 0.0
        self._to_quadrature(self.sig_q, self.stress, 4)
        raise NoConvergence(
            f"Newton did not converge (gravity {gravity_factor}, load {load_factor})"
        )

    def _commit(self, stress, kappa):
        self.stress[:] = stress
        self.kappa[:] = kappa
        self.u.x.array[:] += self.du.x.array
        if self.updated_lagrangian:
            self.move_mesh(self.du)
        self.du.x.array[:] = 0.0

    def move_mesh(self, increment, sign=1.0):
        """Updated Lagrangian: move the geometry nodes by the increment (values at the nodes);
        the unit weight of each cell becomes gamma0 A0 / A (mass conservation)."""
        values = increment.x.array if hasattr(increment, "x") else increment
        values = values.reshape(-1, 2)
        self.mesh.geometry.x[:, :2] += sign * values[self.node_dof]
        self.geometry_version += 1
        self.unit_weight.x.array[self.dg0_dofs] = (
            self.unit_weight0 * self.area0 / self.cell_areas()
        )

    def cell_vertices(self):
        """(n_cells, k, 2) vertex coordinates in cyclic order (current geometry)."""
        p = self.mesh.geometry.x[
            self.mesh.geometry.dofmap.array.reshape(self.n_cells, -1), :2
        ]
        # dolfinx quads: tensor order
        return p[:, [0, 1, 3, 2]] if p.shape[1] == 4 else p

    def cell_areas(self):
        """Areas of the straight-sided cells (current geometry)."""
        p = self.cell_vertices()
        q = np.roll(p, -1, axis=1)
        return 0.5 * np.abs(
            np.sum(p[:, :, 0] * q[:, :, 1] - q[:, :, 0] * p[:, :, 1], axis=1)
        )

    def cell_heights(self):
        """Smallest height of each cell: area / longest edge (triangles: x 2)."""
        p = self.cell_vertices()
        longest = np.linalg.norm(np.roll(p, -1, axis=1) - p, axis=2).max(axis=1)
        factor = 2.0 if p.shape[1] == 3 else 1.0
        return factor * self.cell_areas() / longest

    # ------------------------------------------------------------------ initial stress
    def set_k0_stress(self, k0=None):
        """sigma_v = -unit weight x depth below the local surface, sigma_h = sigma_zz = K0 sigma_v
        (K0 = nu / (1 - nu) of each material unless given)."""
        xq = self.quadrature_coordinates()
        top = surface_height(self.polygons, xq[:, 0])
        depth = np.maximum(top - xq[:, 1], 0.0)
        for model, idx in zip(self.models, self.groups):
            mat = model.material
            gamma = mat.unit_weight if self.case.g > 0 else 0.0
            coeff = (
                k0 if k0 is not None else mat.poisson_ratio / (1.0 - mat.poisson_ratio)
            )
            sv = -gamma * depth[idx]
            self.stress[idx, 0] = coeff * sv
            self.stress[idx, 1] = sv
            self.stress[idx, 2] = 0.0
            self.stress[idx, 3] = coeff * sv
        self._to_quadrature(self.sig_q, self.stress, 4)

    def reset_displacements(self):
        """Gravity procedure: keep stress and kappa, set the displacement to zero (and, updated
        Lagrangian, move the mesh back to the initial geometry, as the MPM resets positions).
        """
        if self.updated_lagrangian:
            self.move_mesh(self.u, sign=-1.0)
        self.u.x.array[:] = 0.0

    # ------------------------------------------------------------------ outputs
    def boundary_loops(self):
        """Ordered deformed outer boundary: list of (n, 2) arrays, counter-clockwise for the
        outer loops (material on the left), first point lowest-then-leftmost, no closing point.
        Points: the geometry vertices and (P2) the facet mid-side nodes, at X + u."""
        xg0 = self.dof_coords0
        disp = self.u.x.array.reshape(-1, 2)
        vdof = self.vertex_dof
        succ = {}
        mids = {}
        for va, vb in self.exterior_facets:
            succ[va] = vb
            if self.degree == 2:
                mid = 0.5 * (xg0[vdof[va]] + xg0[vdof[vb]])
                mids[va] = self.dof_tree.query(mid)[1]
        loops = []
        seen = set()
        for start in list(succ):
            if start in seen:
                continue
            chain = []
            v = start
            while v not in seen:
                seen.add(v)
                chain.append(vdof[v])
                if v in mids:
                    chain.append(mids[v])
                v = succ[v]
            pts = xg0[chain] + disp[chain]
            low = np.min(pts[:, 1])
            cand = np.nonzero(pts[:, 1] <= low + 1e-12 * max(1.0, abs(low)))[0]
            first = cand[np.argmin(pts[cand, 0])]
            loops.append(np.roll(pts, -first, axis=0))
        area = [
            0.5
            * np.sum(p[:, 0] * np.roll(p[:, 1], -1) - np.roll(p[:, 0], -1) * p[:, 1])
            for p in loops
        ]
        return [loops[i] for i in np.argsort(-np.abs(area))]

    def cell_average(self, values):
        """Quadrature-weighted mean over each cell's points, rows in cell order."""
        w = self.qweights / self.qweights.sum()
        return np.einsum("cqk,q->ck", values.reshape(self.n_cells, self.nq, -1), w)


def _node_set_test(node_set, tol):
    """x (3, n) -> whether each point is in the node set: in its closed box, or within tol of
    one of its segments (a gmsh physical group, case.py)."""
    if not isinstance(node_set, dict):
        (bx0, by0), (bx1, by1) = node_set
        return lambda x: (
            (x[0] >= bx0 - tol)
            & (x[0] <= bx1 + tol)
            & (x[1] >= by0 - tol)
            & (x[1] <= by1 + tol)
        )
    a, b = node_set["segments"][:, 0], node_set["segments"][:, 1]

    def inside(x):
        p = x[:2].T[:, None, :]  # (n, 1, 2) against (k, 2)
        ab = b - a
        length2 = np.maximum((ab * ab).sum(axis=1), np.finfo(float).tiny)
        t = np.clip(((p - a) * ab).sum(axis=2) / length2, 0.0, 1.0)
        distance = np.linalg.norm(a + t[:, :, None] * ab - p, axis=2)
        return distance.min(axis=1) <= tol

    return inside
