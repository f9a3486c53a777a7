#pragma once
// Exact per-diamond field errors of the HT (internal).
#include <vector>

#include "tetlod/models/ht/ht_model.hpp"
#include "tetlod/core/zeroed_allocator.hpp"

namespace tetlod::ht {

/// For every grid point c of the data box that is a diamond centre: the largest,
/// over the diamond's tets lying inside the data box, of the exact tet error
/// max |f(p) - L_T(p)| over the grid points p of the closed tet. +inf when one of
/// its tets crosses the data box's boundary (it must always split); 0 at cube
/// corners. Rounded up to float so a stored error never understates the true one.
ZeroedVector<float> compute_diamond_errors(const Volume& field, const HtDomain& domain);

}  // namespace tetlod::ht
