"""Vectorised plane-strain constitutive updates (numpy), the same models as mpm/core/materials.hpp.

Conventions: tension positive; stress rows (sxx, syy, sxy, szz) in kPa; strain increments rows
(dxx, dyy, dgamma_xy = 2 deps_xy), dzz = 0 (plane strain).

Plastic models, written in the sorted principal stresses s1 >= s2 >= s3 of the full 3D stress
(szz included):
  Mohr-Coulomb  f = (s1 - s3) + (s1 + s3) sin(phi) - 2 c(kappa) cos(phi)
  Tresca        the same with phi = 0, i.e. f = 2 [ (s1 - s3)/2 - c(kappa) ], associated flow.
Plastic potential g: the same expression with the dilation angle psi (psi = phi = 0 for Tresca).
Mohr-Coulomb tension cut-off: Rankine planes T_I = s_I - sigma_t,eff(c) with associated flow,
sigma_t,eff = min(tension_cutoff, c(kappa) / tan(phi)) for phi > 0 (tension_cutoff for phi = 0);
Tresca has none.
Return mapping: implicit (backward Euler) in principal stress space with the isotropic elastic
matrix D = lambda 1 1^T + 2 mu I: sigma = sigma_trial - sum_l dlambda_l D b_l with the active
planes' conditions F_j = 0 (c at the end of the step, Newton on the multipliers). The sets of
active planes are tried in the order of mpm/core/materials.cpp - {F13}, {F13, F23}, {F13, F12},
then with a cut-off {T1}, {F13, T1}, {T1, T2}, {F13, F12, T1}, {F13, T1, T2}, {F13, F23, T1},
{T1, T2, T3}, and {F13, F23, F12} for psi > 0 - and the first whose stress is admissible (all
multipliers >= 0, inside every plane) is taken; if none, the least violating one.
Eigenvectors are kept (isotropy), so the in-plane stress is rebuilt from the returned in-plane
principal values.

Softening variable kappa (equivalent plastic strain), as mpm/core/materials.cpp: the
accumulated plastic shear strain of the shear planes, d kappa = sum over the active planes
(I, J) of dlambda_IJ (b_IJ[I] - b_IJ[J]) = 2 sum dlambda_IJ (multipliers of F above), i.e.
eps1_p - eps3_p on the main plane (gamma_xy^p in simple shear); c d kappa is the plastic
dissipation of associated Tresca. `kappa_measure="von_mises"` switches to
d kappa = sqrt(2/3 de_p : de_p) of the deviatoric plastic strain increment instead.

Consistent tangent: central finite differences of the (exact, vectorised) return map with
respect to the three in-plane strain components, so Newton converges quadratically away from
the kinks of the return map.
"""
from __future__ import annotations

import numpy as np


class ElasticPlasticModel:
    """One material: linear elastic, Tresca or Mohr-Coulomb (the case `model`)."""

    def __init__(self, material, kappa_measure: str = "plastic_shear"):
        self.material = material
        self.lam = material.lame_lambda
        self.mu = material.shear_modulus
        self.plastic = material.model != "linear_elastic"
        if material.model == "tresca":
            phi = psi = 0.0
        else:
            phi, psi = np.radians(material.friction_angle), np.radians(
                material.dilation_angle
            )
        self.sin_phi, self.cos_phi, self.sin_psi = np.sin(phi), np.cos(phi), np.sin(psi)
        self.tension_cutoff = (
            material.tension_cutoff if material.model == "mohr_coulomb" else None
        )
        self.cohesion = material.cohesion
        if kappa_measure not in ("plastic_shear", "von_mises"):
            raise ValueError("kappa_measure must be plastic_shear or von_mises")
        self.kappa_measure = kappa_measure
        self.D = self.lam * np.ones((3, 3)) + 2.0 * self.mu * np.eye(3)

    # ---------------------------------------------------------------- elastic
    def elastic_matrix(self):
        """3x3 plane-strain matrix for (sxx, syy, sxy) against (exx, eyy, gxy)."""
        lam, mu = self.lam, self.mu
        return np.array(
            [[lam + 2 * mu, lam, 0.0], [lam, lam + 2 * mu, 0.0], [0.0, 0.0, mu]]
        )

    def trial(self, stress, dstrain):
        lam, mu = self.lam, self.mu
        vol = dstrain[:, 0] + dstrain[:, 1]
        out = stress.copy()
        out[:, 0] += lam * vol + 2 * mu * dstrain[:, 0]
        out[:, 1] += lam * vol + 2 * mu * dstrain[:, 1]
        out[:, 2] += mu * dstrain[:, 2]
        out[:, 3] += lam * vol
        return out

    # ---------------------------------------------------------------- plastic
    def _dkappa(self, dlam, B):
        """Increment of kappa from the multipliers dlam (n, m) of the flow directions B (m, 3)."""
        if self.kappa_measure == "plastic_shear":
            return dlam @ (B.max(axis=1) - B.min(axis=1))
        dep = dlam @ B
        dev = dep - dep.mean(axis=1, keepdims=True)
        return np.sqrt(2.0 / 3.0 * np.sum(dev * dev, axis=1))

    def tension_limit(self, c):
        """sigma_t,eff(c) = min(tension_cutoff, c / tan(phi)) (phi > 0), tension_cutoff (phi = 0),
        +inf without a cut-off (Tresca)."""
        if self.tension_cutoff is None:
            return np.full_like(c, np.inf)
        if self.sin_phi > 0.0:
            return np.minimum(self.tension_cutoff, c * self.cos_phi / self.sin_phi)
        return np.full_like(c, self.tension_cutoff)

    def _tension_limit_slope(self, c):
        if self.tension_cutoff is None or self.sin_phi == 0.0:
            return np.zeros_like(c)
        return np.where(
            c * self.cos_phi / self.sin_phi < self.tension_cutoff,
            self.cos_phi / self.sin_phi,
            0.0,
        )

    def _planes(self):
        """Yield planes in the ordered principal frame: name -> (a, b, is_shear)."""
        sp, ss = self.sin_phi, self.sin_psi
        planes = {}
        for i, j in ((0, 2), (1, 2), (0, 1)):
            a, b = np.zeros(3), np.zeros(3)
            a[i], a[j] = 1 + sp, -(1 - sp)
            b[i], b[j] = 1 + ss, -(1 - ss)
            planes[f"F{i + 1}{j + 1}"] = (a, b, True)
        for i in range(3):
            e = np.zeros(3)
            e[i] = 1.0
            planes[f"T{i + 1}"] = (e, e, False)
        return planes

    def _active_sets(self):
        """Sets of active planes, tried in this order (as mpm/core/materials.cpp)."""
        sets = [["F13"], ["F13", "F23"], ["F13", "F12"]]
        if self.tension_cutoff is not None:
            sets += [
                ["T1"],
                ["F13", "T1"],
                ["T1", "T2"],
                ["F13", "F12", "T1"],
                ["F13", "T1", "T2"],
                ["F13", "F23", "T1"],
                ["T1", "T2", "T3"],
            ]
        if self.sin_psi > 0.0:
            sets.append(["F13", "F23", "F12"])
        return sets

    def _solve_set(self, s_trial, kappa, names):
        """Backward-Euler return onto the planes `names` with softening of c(kappa).

        Returns (sigma (n,3), dlambda (n,m), dkappa (n,))."""
        planes = self._planes()
        A = np.array([planes[k][0] for k in names])
        B = np.array([planes[k][1] for k in names])
        shear = np.array([planes[k][2] for k in names])
        DB = B @ self.D
        ADB = A @ DB.T
        # d kappa / d dlambda_j
        weight = np.where(shear, B.max(axis=1) - B.min(axis=1), 0.0)
        a_s = A @ s_trial.T  # (m, n)

        def limits(c):
            return np.where(
                shear[:, None],
                2.0 * self.cos_phi * c[None, :],
                self.tension_limit(c)[None, :],
            ).T  # (n, m)

        def limit_slopes(c):
            return np.where(
                shear[:, None],
                2.0 * self.cos_phi,
                self._tension_limit_slope(c)[None, :],
            ).T

        def dkappa_of(dlam):
            if self.kappa_measure == "plastic_shear":
                return dlam @ weight
            dep = (dlam * shear) @ B
            dev = dep - dep.mean(axis=1, keepdims=True)
            return np.sqrt(2.0 / 3.0 * np.sum(dev * dev, axis=1))

        c_n = self.cohesion.value(kappa)
        f_trial = a_s.T - limits(c_n)
        try:
            dlam = np.linalg.solve(ADB, f_trial.T).T
        except np.linalg.LinAlgError:
            dlam = np.linalg.lstsq(ADB, f_trial.T, rcond=None)[0].T
        for _ in range(30):
            dk = dkappa_of(dlam)
            c = self.cohesion.value(kappa + dk)
            resid = a_s.T - dlam @ ADB.T - limits(c)
            if np.all(np.abs(resid) <= 1e-10 * (1.0 + np.abs(f_trial))):
                break
            slope = self.cohesion.slope(kappa + dk)
            if self.kappa_measure == "plastic_shear":
                ddk = np.broadcast_to(weight, dlam.shape)
            else:
                dep = (dlam * shear) @ B
                dev = dep - dep.mean(axis=1, keepdims=True)
                Bdev = (B - B.mean(axis=1, keepdims=True)) * shear[:, None]
                first = np.sqrt(2.0 / 3.0 * np.sum(Bdev * Bdev, axis=1))
                safe = np.where(dk > 1e-300, dk, 1.0)
                ddk = np.where(
                    dk[:, None] > 1e-300,
                    (2.0 / 3.0) * (dev @ Bdev.T) / safe[:, None],
                    first[None, :],
                )
            J = (
                -ADB[None, :, :]
                - (limit_slopes(c) * slope[:, None])[:, :, None] * ddk[:, None, :]
            )
            dlam = dlam - np.linalg.solve(J, resid[:, :, None])[:, :, 0]
        sigma = s_trial - dlam @ DB
        return sigma, dlam, dkappa_of(dlam)

    def _violation(self, sigma, kappa, dlam=None):
        """How far a stress is outside the yield surface (kPa, <= 0 inside), multipliers < 0 too."""
        c = self.cohesion.value(kappa)
        smax, smin = sigma.max(axis=1), sigma.min(axis=1)
        f = (smax - smin) + (smax + smin) * self.sin_phi - 2.0 * c * self.cos_phi
        if self.tension_cutoff is not None:
            f = np.maximum(f, smax - self.tension_limit(c))
        if dlam is not None:
            f = np.maximum(f, -dlam.min(axis=1) * 2.0 * self.mu)
        return f

    def _return_principal(self, s, kappa):
        """s (n,3) sorted principal trial stresses of yielding points: the first admissible set
        of active planes; if none is admissible, the least violating one."""
        n = s.shape[0]
        sigma = np.zeros_like(s)
        dk = np.zeros(n)
        best = np.full(n, np.inf)
        open_points = np.ones(n, dtype=bool)
        tol = 1e-9 * (1.0 + np.abs(s).max(axis=1))
        for names in self._active_sets():
            idx = np.nonzero(open_points)[0]
            if idx.size == 0:
                break
            sg, dl, dkk = self._solve_set(s[idx], kappa[idx], names)
            viol = self._violation(sg, kappa[idx] + dkk, dl)
            viol = np.where(np.isfinite(viol), viol, np.inf)
            better = viol < best[idx]
            take = idx[better]
            sigma[take], dk[take], best[take] = sg[better], dkk[better], viol[better]
            open_points[idx[viol <= tol[idx]]] = False
        return sigma, dk

    def update(self, stress, kappa, dstrain):
        """Stress (n,4), kappa (n,), strain increment (n,3) -> new stress, new kappa."""
        trial = self.trial(stress, dstrain)
        if not self.plastic:
            return trial, kappa.copy()
        new_kappa = kappa.copy()
        p = 0.5 * (trial[:, 0] + trial[:, 1])
        d = 0.5 * (trial[:, 0] - trial[:, 1])
        r = np.hypot(d, trial[:, 2])
        small = r < 1e-14 * (1.0 + np.abs(p))
        rs = np.where(small, 1.0, r)
        c2 = np.where(small, 1.0, d / rs)
        s2 = np.where(small, 0.0, trial[:, 2] / rs)
        triple = np.stack([p + r, p - r, trial[:, 3]], axis=1)
        order = np.argsort(-triple, axis=1, kind="stable")
        s = np.take_along_axis(triple, order, axis=1)
        yielding = self._violation(s, kappa) > 1e-10 * (
            1.0 + np.abs(self.cohesion.value(kappa))
        )
        if np.any(yielding):
            sig, dk = self._return_principal(s[yielding], kappa[yielding])
            back = np.empty_like(sig)
            np.put_along_axis(back, order[yielding], sig, axis=1)
            pn = 0.5 * (back[:, 0] + back[:, 1])
            rn = 0.5 * (back[:, 0] - back[:, 1])
            out = trial[yielding]
            out[:, 0] = pn + rn * c2[yielding]
            out[:, 1] = pn - rn * c2[yielding]
            out[:, 2] = rn * s2[yielding]
            out[:, 3] = back[:, 2]
            trial[yielding] = out
            new_kappa[yielding] += dk
        return trial, new_kappa

    def update_with_tangent(self, stress, kappa, dstrain):
        """New stress, kappa and the 3x3 algorithmic tangent d(sxx, syy, sxy)/d(exx, eyy, gxy)."""
        new_stress, new_kappa = self.update(stress, kappa, dstrain)
        n = stress.shape[0]
        tangent = np.broadcast_to(self.elastic_matrix(), (n, 3, 3)).copy()
        if not self.plastic:
            return new_stress, new_kappa, tangent
        # Only points that are (or are close to being) plastic need a numerical tangent.
        plastic = (new_kappa > kappa) | self._near_yield(new_stress, new_kappa)
        if np.any(plastic):
            idx = np.nonzero(plastic)[0]
            step = 1e-7 * np.maximum(1e-3, np.abs(dstrain[idx]).max(axis=1))
            for j in range(3):
                de = np.zeros((idx.size, 3))
                de[:, j] = step
                sp, _ = self.update(stress[idx], kappa[idx], dstrain[idx] + de)
                sm, _ = self.update(stress[idx], kappa[idx], dstrain[idx] - de)
                tangent[idx, :, j] = (sp[:, :3] - sm[:, :3]) / (2.0 * step[:, None])
        return new_stress, new_kappa, tangent

    def _near_yield(self, stress, kappa):
        p = 0.5 * (stress[:, 0] + stress[:, 1])
        r = np.hypot(0.5 * (stress[:, 0] - stress[:, 1]), stress[:, 2])
        tri = np.stack([p + r, p - r, stress[:, 3]], axis=1)
        return self._violation(tri, kappa) > -1e-6 * (1.0 + self.cohesion.value(kappa))
