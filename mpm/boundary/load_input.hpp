// Case-file entry of a load on the detected boundary (an element of "loads" with
// "apply_on": "detected_boundary"). Keys, units and defaults:
// clang-format off
//
// | key                    | unit | default                          | meaning                                        |
// |------------------------|------|----------------------------------|------------------------------------------------|
// | apply_on               |      | required                         | must be "detected_boundary"                    |
// | type                   |      | required                         | vertical_pressure, follower_pressure, traction |
// | pressure               | kPa  | required for the two pressures   | q >= 0 (vertical, downward); p (follower,      |
// |                        |      |                                  | > 0 pushes on the material, any sign)          |
// | traction               | kPa  | required for traction            | [tx, ty] per current length                    |
// | x_range                | m    | required for vertical_pressure,  | [x0, x1], x0 < x1; load only where             |
// |                        |      | else the whole boundary          | x0 <= x <= x1                                  |
// | faces                  |      | "top" (vertical_pressure),       | "top": upward parts with no boundary above;    |
// |                        |      | "all" (others)                   | "upward": n_y > 0 (thesis); "all"              |
// | curve                  |      | "linear"                         | linear, quadratic, cubic (C2, eq. 4.3),        |
// |                        |      |                                  | catmull_rom                                    |
// | integration            |      | "exact"                          | exact, thesis (eq. 6.12 as printed)            |
// | gauss_points           |      | 5                                | k, 1..20                                       |
// | split_at_cell_edges    |      | true (exact), false (thesis)     | cut segments at cell edges first               |
// | scale_eq_6_15          |      | false                            | scale to the exact total (eq. 6.15)            |
// | redistribute_lost_load |      | true                             | move force off nodes too light to carry it     |
// | min_node_mass_fraction |      | 0.01                             | "too light": mass <= f x a full cell's, [0, 1) |
// | interval               |      | "fixed"                          | fixed (thesis 6.2) or material                 |
// | normal                 |      | none (any normal)                | {"direction": [nx, ny], "max_angle": deg}:     |
// |                        |      |                                  | only segments whose outward normal is within   |
// |                        |      |                                  | max_angle of direction (a face of a body)      |
// | time_function          |      | constant                         | read by the case reader                        |
//
// clang-format on
#pragma once

#include "mpm/boundary/surface_load.hpp"
#include "mpm/core/json_input.hpp"

namespace pfm::boundary {

/// Parses and validates one load entry; InputError naming the JSON pointer on bad input.
BoundaryLoadSpec parse_boundary_load(const pfm::JsonView& entry);

/// The keys that select a part of the detected boundary, as for loads (x_range, faces, normal,
/// curve, interval), into spec; shared with the constraints on the detected boundary.
void parse_boundary_part(const pfm::JsonView& entry, bool x_range_required,
                         const char* default_faces, BoundaryLoadSpec& spec);

}  // namespace pfm::boundary
