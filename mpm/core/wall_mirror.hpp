// Supports inside the grid with B-splines: the node behind a wall as the mirror image of the
// node in front of it. Shared by every solver on the background grid, as the ties of
// basis_extension.hpp.
//
// B-splines do not interpolate. A support given as a node set inside the grid (a wall with the
// nodes behind it, as uGIMP needs) fixes a component d on the wall's node line W and behind it;
// the function of the first node behind, I = W - s (s the step into the body), reaches into the
// body (half a cell for quadratic splines, one cell for cubic ones), and with v_I = v_W = 0 the
// field on the wall is N_J(x_W) v_J, J = W + s: 1/8 of the first free node's value (1/6 cubic).
// The wall gives way, and a body resting on it settles too much.
//
// The mirror makes the component odd about the wall, v_I = w v_J with w = -N_J(x_W) / N_I(x_W)
// along the wall's normal axis (-1 for the uniform splines; another value where I's function is
// modified at the grid's clamped edge), so that the field vanishes on the whole wall line, as on
// a support on the grid's edge: the antisymmetric extension across a plane of symmetry, which is
// what a smooth wall is for the component it holds. The components a wall leaves free keep
// their nodes' own unknowns (or their ties).
//
// In a step, as the ties: what the particles and loads give I's component d is gathered onto J's,
// x_J += w x_I, and I's is emptied; J's lumped mass for that component is the row sum of its
// extended function N_J + w N_I, m_J + w m_I (summed over every I that J mirrors for d: a node
// by an inside corner mirrors two). The grid keeps one mass per node, so the gathered component
// is scaled by m_J / (m_J + w m_I): the node's update then gives that component the velocity and
// acceleration of its own mass. After the update I's component is w times J's.
//
// Which nodes: I fixed in d at zero velocity (not by a moving condition), the next node in one
// axis direction fixed in d (W), the one after it free in d (J), and the node on I's far side
// fixed in d as well or beyond the grid (I is behind the wall, not the face of a held region two
// nodes thick); in exactly one of the four directions. Behind the inside corner of two walls that
// both hold d (a base and a wall), the node diagonally behind the corner is mirrored across both, J
// = I + 2 (sx, sy), with the product of the two weights, so that the field vanishes on both wall
// lines up to the corner. A node two or more behind a wall reaches no point in the body (supports
// 3h and 4h). In a step where J is an outer node (tied) or would keep less than half its mass (m_J
// + w m_I < m_J / 2: the top of a wall with a sliver of material) the mirror is off and I stays
// fixed. Linear functions and uGIMP interpolate at the wall and take no mirrors.
//
// Cost: work proportional to the wall's nodes, per step.
#pragma once

#include <span>
#include <vector>

#include "mpm/core/basis_extension.hpp"
#include "mpm/core/grid.hpp"
#include "mpm/core/shape_functions.hpp"

namespace pfm {

class WallMirror {
 public:
  /// One behind node of an image: I's component takes weight x J's.
  struct Source {
    int behind = 0;
    double weight = 0.0;
  };
  /// A node J and one of its components that mirrors its sources across walls.
  struct Image {
    int node = 0;
    int component = 0;  ///< 0: x, 1: y
    std::vector<Source> sources;
  };

  WallMirror() = default;
  /// fixed_at_zero: per node, the components held at zero velocity for the whole run (FixMask).
  /// No mirrors unless `kind` is a B-spline.
  WallMirror(const Grid& grid, ShapeFunctionKind kind, std::span<const unsigned> fixed_at_zero);

  bool empty() const { return images_.empty(); }
  const std::vector<Image>& images() const { return images_; }

  /// This step's images and scales from the nodal masses (before any gather); ties: the step's
  /// outer nodes (null without ties).
  void prepare(std::span<const double> mass, const BasisExtension* ties);
  /// Whether image k acts this step, and its scale m_J / (m_J + sum w m_I).
  bool active(std::size_t k) const { return scale_[k] > 0.0; }
  double scale(std::size_t k) const { return scale_[k]; }

  /// x_J = scale (x_J + sum w x_I) and x_I = 0 on the mirrored components.
  void gather(std::span<Vec2> values) const;
  /// Keeps J's mirrored components of `values` (before loads are added to it).
  void hold(std::span<const Vec2> values);
  /// gather() for what was added to `values` since hold(): J's component becomes
  /// held + scale (added at J + sum w x_I), x_I = 0.
  void gather_added(std::span<Vec2> values) const;
  /// x_I = w x_J on the mirrored components.
  void extrapolate(std::span<Vec2> values) const;

  /// The image whose node is `node` for component d, -1 if none.
  int image_at(int node, int d) const { return at(image_at_, node, d); }
  /// The image that `node`'s component d is a source of, -1 if none; weight: its w.
  int source_at(int node, int d, double& weight) const {
    const int k = at(source_at_, node, d);
    if (k >= 0) weight = source_weight_[static_cast<std::size_t>(2 * node + d)];
    return k;
  }

 private:
  /// x_J = base + scale (x_J - base + sum w x_I), x_I = 0; base: held_ or 0.
  void gather_onto(std::span<Vec2> values, bool from_held) const;
  static int at(const std::vector<int>& v, int node, int d) {
    return v.empty() ? -1 : v[static_cast<std::size_t>(2 * node + d)];
  }
  std::vector<Image> images_;
  std::vector<int> image_at_, source_at_;  ///< per node and component
  std::vector<double> source_weight_;      ///< per node and component
  std::vector<double> scale_;              ///< per image this step, 0 when off
  std::vector<double> held_;               ///< per image, hold()
};

}  // namespace pfm
