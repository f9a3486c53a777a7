#pragma once
// Built-in analytic volumes: test inputs that need no data files. Each is a
// function f on the cube [-1,1]^3 with values in [0,1], sampled at the grid
// points x_i = -1 + 2 i / (dims.x - 1) (likewise y, z). The volume's geometry
// matches: spacing 2/(dims-1), origin -1, so meshes appear in [-1,1]^3.
//
// Quantisation: for integer types, value q = round(lo + f * (hi - lo)) with
// [lo, hi] the full range of the type (u8: 0..255, i8: -128..127, u16: 0..65535,
// ...); for f32/f64 the value is f itself. Deterministic: plain libm calls
// and a fixed evaluation order, no randomness.
//
// The volumes (r = |p|, p = (x, y, z)):
//
//  "marschner-lobb"  The Marschner-Lobb test signal (Marschner & Lobb, "An
//      evaluation of reconstruction filters for volume rendering", Vis 1994) with
//      the standard parameters fM = 6, alpha = 0.25:
//        f = (1 - sin(pi z / 2) + alpha (1 + rho(sqrt(x^2 + y^2)))) / (2 (1 + alpha)),
//        rho(s) = cos(2 pi fM cos(pi s / 2)).
//      Range [0, 1]. Most of its energy is near the Nyquist rate of a 41^3 grid,
//      which makes it a hard case for any simplification.
//
//  "multiscale"  Features at several scales, all smooth:
//        g = 0.15 (x + y + z + 3) / 6                       low-frequency gradient
//          + 0.45 exp(-|p - (-0.3,-0.2,-0.1)|^2 / (2 0.35^2)) wide blob
//          + 0.25 exp(-|p - ( 0.45, 0.4, 0.35)|^2 / (2 0.12^2)) medium blob
//          + 0.15 exp(-|p - ( 0.5,-0.55, 0.5)|^2 / (2 0.04^2)) narrow blob
//          + 0.025 (1 + sin(8 pi x) sin(8 pi y) sin(8 pi z)) fine ripple
//        f = g / 1.05 (the sum of the maxima), so f lies in [0, 1].
//      Coarse meshes capture the gradient and the wide blob; the narrow blob and
//      the ripple need the finest levels.
//
//  "sphere"  Distance-like radial field: f = 1 - r / sqrt(3), 1 at the centre,
//      0 at the cube corners. The isosurface f = v is the sphere of radius
//      sqrt(3) (1 - v), e.g. v = 0.5 gives radius 0.866.
//
// Archival cases (issue 13), hard for a predictive coder in other ways:
//
//  "sparse"  Five balls of radius 0.15 (centres fixed in the source), f = 1 -
//      d^2 / 0.15^2 inside each (the largest where they meet), 0 elsewhere:
//      about 99% of the samples are exactly 0.
//
//  "constant"  f = 0.5 everywhere.
//
//  "noisy"  0.8 multiscale + 0.2 u, u uniform white noise in [0, 1) hashed from
//      the coordinates' bit patterns (splitmix64): smooth structure under
//      several bits of noise per sample, still deterministic.
#include <string>
#include <vector>

#include "tetlod/core/volume.hpp"

namespace tetlod {

/// Names of the built-in volumes, in a fixed order.
std::vector<std::string> sample_volume_names();

/// Samples the named volume on a grid of `dims` (each at least 2) as `type`.
/// metadata["sample"] holds the name; field_name is the name too.
/// Throws tetlod::Error(InvalidArgument) for an unknown name (listing the known
/// ones) or dims below 2, TooLarge for dims beyond the limits.
Volume make_sample_volume(const std::string& name, Dims dims, ValueType type = ValueType::U8);

}  // namespace tetlod
