// Basic types shared by every solver of the project.
//
// Units (one consistent system, everywhere): length m, force kN, time s, mass t (tonne),
// stress and pressure kPa (= kN/m^2), unit weight kN/m^3, density t/m^3.
// 2D plane strain: the out-of-plane normal stress sigma_zz is kept, the out-of-plane strain is 0.
// Sign convention: tension positive (soil under self-weight has negative sigma_yy).
#pragma once

#include <Eigen/Core>
#include <Eigen/LU>  // determinant()

namespace pfm {

using Vec2 = Eigen::Vector2d;
using Mat2 = Eigen::Matrix2d;

/// Cauchy stress in plane strain, Voigt order (xx, yy, xy, zz), kPa, tension positive.
using Stress = Eigen::Vector4d;

/// Strain (or strain increment) in plane strain, order (xx, yy, gamma_xy = 2 eps_xy, zz).
/// The zz entry is 0 in plane strain; it is kept so strain and stress have the same shape.
using Strain = Eigen::Vector4d;

enum VoigtIndex : int { kXX = 0, kYY = 1, kXY = 2, kZZ = 3 };

/// Direction bits of a constraint (of a node in the grid update).
enum FixMask : unsigned { kFixNone = 0u, kFixX = 1u, kFixY = 2u, kFixXY = 3u };

}  // namespace pfm
