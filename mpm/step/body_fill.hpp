// Filling bodies with material points (thesis 3.2, 5.3.3), and the K0 stress of their points.
#pragma once

#include <vector>

#include "mpm/step/case.hpp"
#include "mpm/step/particles.hpp"

namespace pfm {

/// Height of the polygon's top above x: the largest y of the polygon boundary on the vertical
/// line through x, or NaN if the line misses the polygon. Used as the local surface for K0.
double polygon_top(const std::vector<Vec2>& polygon, double x);

/// The K0 procedure (shared by the MPM and the UL-FEM): sigma_v = -unit weight x depth below
/// the local surface of the point's body polygon (polygon_top), sigma_xx = sigma_zz = K0
/// sigma_v, sigma_xy = 0; K0 from the case or nu / (1 - nu) of the point's material.
void apply_k0_stress(const Case& c, Particles& particles);

/// Natural positions in [0, 1] and weights (summing to 1) of the n points of a placement.
void placement_points_1d(Placement placement, int n, std::vector<double>& position,
                         std::vector<double>& weight);

/// Fill every body with n x n points per cell whose point lies inside the body polygon; a point
/// inside several bodies belongs to the first. Volume = cell area x the point's weight
/// (1/n^2 for equal spacing, the Gauss weight product for Gauss placement); mass = density x
/// volume with density = unit weight / g (g = 9.81 m/s^2 when gravity is 0).
///
/// Conforming placement: as equal spacing, but each of the n x n sub-squares of a cell that the
/// polygon's edges cut holds one point at the centroid of its part inside the polygon, with
/// that part's area as its volume (a part below a quarter of a sub-square joins the nearest
/// part of its cell, and a cell whose only part is that small, where the polygon clips its
/// corner, gives it to the nearest part of a neighbouring cut cell: a sliver of a point, alone on
/// its nodes, would be flung by a constraint). The points' volumes then add up to the polygon's
/// area and their first moment to its first moment, and the point sums of the linear shape
/// functions' gradients (linear within a sub-square) are the integrals over the polygon, exactly,
/// where the staircase of whole sub-squares misses part of the area (test_body_fill checks the
/// area and first moment against the polygon's). test_boundary_coupling runs
/// its free square (turned 20 degrees, a follower pressure) with both placements and asserts the
/// stress more than one cell inside within 3 % of the exact state.
Particles fill_bodies(const Case& c);

/// The particles' spacing in the initial state (the detectors' reference spacing), m: the
/// smallest cell size / points per cell over the bodies, and the side of the smallest point of a
/// body read from a particle file.
double initial_particle_spacing(const Case& c);

}  // namespace pfm
