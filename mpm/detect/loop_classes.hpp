// What each loop of a detected boundary is: material (the body, or an island of material that
// has separated), a real hole, or spurious.
//
// * A loop with the material on its left (contour.hpp) that runs counter-clockwise, or an open
//   chain, bounds material. A closed one is a `spurious_loop` if no particle lies inside it.
//   Of the others, the one of largest area is the `body`; every other is an `island` (material
//   that separated from it, or another body of the case), unless one of its points lies within
//   1.5 initial spacings of a point outside it: then the material is still in contact and the
//   loop is a `spurious_island` (the field split a row of points or a thin neck). Open chains,
//   which end on the grid edge, count as bodies.
// * A clockwise loop bounds a hole. It is a `real_hole` if a particle-free disk of one initial
//   spacing (diameter) fits inside it: a centre inside the loop at least half a spacing from the
//   loop and from every particle (tried on a lattice of a quarter spacing); else it is a
//   `spurious_hole` (a gap the field opened between points that are still in contact).
#pragma once

#include <array>
#include <cstddef>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "mpm/core/types.hpp"
#include "mpm/detect/contour.hpp"

namespace pfm {

/// Points closer than this many initial spacings are in contact.
inline constexpr double kContactSpacings = 1.5;

enum class LoopClass { kBody, kIsland, kSpuriousLoop, kSpuriousIsland, kRealHole, kSpuriousHole };

/// The class's name in summaries: "body", "island", "spurious_loop", "spurious_island",
/// "real_hole", "spurious_hole".
const char* loop_class_name(LoopClass c);

struct LoopClasses {
  std::vector<LoopClass> of_loop;  ///< one per contour, in the boundary's order
  /// The contacts of the spurious islands: (particle inside the island, particle outside it
  /// within kContactSpacings), indices into the particles, by island in the boundary's order,
  /// then by increasing particle indices.
  std::vector<std::array<std::size_t, 2>> contacts;
  long bodies = 0, islands = 0, spurious_loops = 0, spurious_islands = 0, real_holes = 0,
       spurious_holes = 0;
  long spurious() const { return spurious_loops + spurious_islands + spurious_holes; }
  /// The counts by class name (loop_class_name()), for summaries.
  std::array<std::pair<const char*, long>, 6> counts() const {
    return {{{"body", bodies},
             {"island", islands},
             {"real_hole", real_holes},
             {"spurious_loop", spurious_loops},
             {"spurious_island", spurious_islands},
             {"spurious_hole", spurious_holes}}};
  }
};

/// Classifies every contour of `boundary` against the particle positions; `spacing` is the
/// particles' initial spacing (m, > 0).
LoopClasses classify_loops(const DetectedBoundary& boundary, std::span<const Vec2> particles,
                           double spacing);

}  // namespace pfm
