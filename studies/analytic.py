"""Closed-form solutions the benchmarks are measured against. Units kN, m, kPa; tension
positive in what is returned unless a docstring says otherwise."""

from __future__ import annotations

import math

import numpy as np


def constrained_modulus(youngs_modulus: float, poisson_ratio: float) -> float:
    """M = E (1 - nu) / ((1 + nu)(1 - 2 nu)), kPa: the 1D (oedometric) modulus."""
    nu = poisson_ratio
    return youngs_modulus * (1 - nu) / ((1 + nu) * (1 - 2 * nu))


def column_surcharge_settlement(
    height: float, surcharge: float, youngs_modulus: float, poisson_ratio: float
) -> float:
    """Top settlement (m, positive down) of a laterally confined elastic column of height H
    under a surcharge q added to a column already in K0 equilibrium: q H / M."""
    return surcharge * height / constrained_modulus(youngs_modulus, poisson_ratio)


def column_settlement(
    height: float,
    surcharge: float,
    unit_weight: float,
    youngs_modulus: float,
    poisson_ratio: float,
) -> float:
    """Top settlement (m, positive down) of a laterally confined elastic column of height H
    loaded from zero stress by its own weight and a surcharge q (small strain):
    q H / M + gamma H^2 / (2 M)."""
    m = constrained_modulus(youngs_modulus, poisson_ratio)
    return surcharge * height / m + unit_weight * height**2 / (2.0 * m)


def column_settlement_large_strain(
    height: float,
    surcharge: float,
    unit_weight: float,
    youngs_modulus: float,
    poisson_ratio: float,
) -> float:
    """The same column with the stress rate M times the logarithmic strain rate (the
    updated-Lagrangian, Jaumann-rate model of the MPM and the UL-FEM): the weight above the
    material point at reference height X is gamma (H - X) whatever the deformation, so the
    stretch is exp(-(q + gamma (H - X)) / M) and the settlement
    H - (M / gamma) exp(-q / M) (1 - exp(-gamma H / M)); for gamma = 0, H (1 - exp(-q / M)).
    """
    m = constrained_modulus(youngs_modulus, poisson_ratio)
    # Written with expm1 so that stiff soils (strains ~1e-7) do not lose every digit:
    # H (1 - e^-a) + e^-a (M / gamma) (x - (1 - e^-x)), a = q / M, x = gamma H / M.
    surcharge_part = -height * math.expm1(-surcharge / m)
    if unit_weight == 0.0:
        return surcharge_part
    x = unit_weight * height / m
    return surcharge_part + math.exp(-surcharge / m) * (m / unit_weight) * (
        x + math.expm1(-x)
    )


def column_displacement(
    y0,
    height: float,
    surcharge: float,
    unit_weight: float,
    youngs_modulus: float,
    poisson_ratio: float,
):
    """Vertical displacement (m, negative down) at reference height y0 (base at 0) of the column
    of column_settlement (small strain): -(q y0 + gamma (H y0 - y0^2 / 2)) / M."""
    m = constrained_modulus(youngs_modulus, poisson_ratio)
    y0 = np.asarray(y0, dtype=float)
    return -(surcharge * y0 + unit_weight * (height * y0 - 0.5 * y0**2)) / m


def column_displacement_large_strain(
    y0,
    height: float,
    surcharge: float,
    unit_weight: float,
    youngs_modulus: float,
    poisson_ratio: float,
):
    """Vertical displacement (m, negative down) at reference height y0 of the column of
    column_settlement_large_strain: the integral of the stretch exp(-(q + gamma (H - X)) / M) - 1
    from the base, (M / gamma) exp(-(q + gamma H) / M) (exp(gamma y0 / M) - 1) - y0 (for
    gamma = 0, y0 (exp(-q / M) - 1))."""
    m = constrained_modulus(youngs_modulus, poisson_ratio)
    y0 = np.asarray(y0, dtype=float)
    if unit_weight == 0.0:
        return y0 * np.expm1(-surcharge / m)
    g = unit_weight / m
    return np.exp(-(surcharge + unit_weight * height) / m) * np.expm1(g * y0) / g - y0


def column_vertical_stress(y, height: float, surcharge: float, unit_weight: float):
    """syy(y) (kPa, tension positive) in a column with base at y = 0: -(q + gamma (H - y))."""
    return -(surcharge + unit_weight * (height - np.asarray(y, dtype=float)))


def strip_vertical_stress(pressure: float, half_width: float, x, depth):
    """Vertical stress (kPa, COMPRESSION positive) in an elastic half-space under a uniform
    strip load q on |x| <= b (plane strain; e.g. Poulos & Davis 1974):
    sigma_z = q / pi (alpha + sin(alpha) cos(alpha + 2 delta)), written with the angles
    theta1 = atan((x - b) / z), theta2 = atan((x + b) / z): alpha = theta2 - theta1 and
    alpha + 2 delta = theta1 + theta2. Under the centre: q / pi (alpha + sin alpha),
    alpha = 2 atan(b / z)."""
    x = np.asarray(x, dtype=float)
    z = np.asarray(depth, dtype=float)
    theta1 = np.arctan2(x - half_width, z)
    theta2 = np.arctan2(x + half_width, z)
    alpha = theta2 - theta1
    return pressure / math.pi * (alpha + np.sin(alpha) * np.cos(theta1 + theta2))


def prandtl_bearing_capacity(cohesion: float) -> float:
    """Collapse pressure (kPa) of a smooth strip footing on weightless Tresca soil:
    (2 + pi) c (Prandtl 1920)."""
    return (2.0 + math.pi) * cohesion


def disk_external_pressure(
    radius: float, pressure: float, youngs_modulus: float, poisson_ratio: float
) -> dict:
    """Plane-strain elastic disk (cylinder) under a uniform external pressure p: homogeneous
    stress srr = stt = -p, szz = -2 nu p, and radial displacement at r = R
    u_r = -p R (1 + nu)(1 - 2 nu) / E."""
    nu = poisson_ratio
    return {
        "srr": -pressure,
        "stt": -pressure,
        "szz": -2.0 * nu * pressure,
        "radial_displacement": -pressure
        * radius
        * (1 + nu)
        * (1 - 2 * nu)
        / youngs_modulus,
    }


def observed_orders(h, errors) -> list:
    """Observed convergence orders log(e_i / e_{i+1}) / log(h_i / h_{i+1}); None first."""
    orders = [None]
    for (h0, e0), (h1, e1) in zip(zip(h, errors), zip(h[1:], errors[1:])):
        if e0 > 0 and e1 > 0 and h0 != h1:
            orders.append(math.log(e0 / e1) / math.log(h0 / h1))
        else:
            orders.append(None)
    return orders


def manufactured_solution(
    reference_xy: np.ndarray,
    time: float,
    amplitude: float,
    period: float,
    origin,
    size,
    youngs_modulus: float,
    poisson_ratio: float,
) -> tuple[np.ndarray, np.ndarray]:
    """The manufactured solution of a case's ``manufactured_solution`` block (the C++ body
    force that drives it: mpm/core/manufactured.hpp): at reference points X (n x 2) and time t,
    u = A (1 - cos(2 pi t / T))^2 / 4 sin(pi (x - x0) / Lx) sin(pi (y - y0) / Ly) (1, 1) and its
    small-strain plane-strain stress. Returns (u (n x 2), stress (n x 4: xx, yy, xy, zz)).
    """
    nu, e = poisson_ratio, youngs_modulus
    lam = e * nu / ((1 + nu) * (1 - 2 * nu))
    mu = e / (2 * (1 + nu))
    kx, ky = math.pi / size[0], math.pi / size[1]
    sx = reference_xy[:, 0] - origin[0]
    sy = reference_xy[:, 1] - origin[1]
    g = amplitude * 0.25 * (1 - math.cos(2 * math.pi * time / period)) ** 2
    phi = np.sin(kx * sx) * np.sin(ky * sy)
    exx = g * kx * np.cos(kx * sx) * np.sin(ky * sy)
    eyy = g * ky * np.sin(kx * sx) * np.cos(ky * sy)
    exy = 0.5 * (exx + eyy)
    trace = exx + eyy
    stress = np.c_[
        lam * trace + 2 * mu * exx,
        lam * trace + 2 * mu * eyy,
        2 * mu * exy,
        lam * trace,
    ]
    return np.c_[g * phi, g * phi], stress


def smooth_ramp(time: float, ramp_time: float) -> float:
    """The smooth_ramp time function: 10 u^3 - 15 u^4 + 6 u^5, u = min(t / t_r, 1)."""
    u = min(max(time / ramp_time, 0.0), 1.0)
    return u**3 * (10.0 - 15.0 * u + 6.0 * u * u)


def manufactured_dilatation(
    reference_xy: np.ndarray,
    time: float,
    pressure: float,
    ramp_time: float,
    centre,
    youngs_modulus: float,
    poisson_ratio: float,
) -> tuple[np.ndarray, np.ndarray]:
    """The uniform-dilatation manufactured solution (mpm/core/manufactured.hpp): a free body
    squeezed by a follower pressure p0 f(t) moves as x = c + s (X - c) with
    s = exp(-p0 f / (2 (lambda + mu))); its stress is sxx = syy = -p0 f, sxy = 0,
    szz = 2 lambda ln s. Returns (u (n x 2), stress (n x 4: xx, yy, xy, zz))."""
    nu, e = poisson_ratio, youngs_modulus
    lam = e * nu / ((1 + nu) * (1 - 2 * nu))
    mu = e / (2 * (1 + nu))
    log_stretch = -pressure * smooth_ramp(time, ramp_time) / (2 * (lam + mu))
    u = (math.exp(log_stretch) - 1.0) * (reference_xy - np.asarray(centre))
    n = len(reference_xy)
    in_plane = 2 * (lam + mu) * log_stretch
    stress = np.tile([in_plane, in_plane, 0.0, 2 * lam * log_stretch], (n, 1))
    return u, stress
