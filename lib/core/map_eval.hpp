// lib/core/map_eval.hpp — the map-system side of the core's public functions
// (internal; lib/core/derivatives.cpp dispatches to these for System::is_map()).
// q: the kept coordinates (n); results as documented in modal/core.hpp.
#pragma once

#include "modal/core.hpp"

namespace modal::map_eval {

double potential(const System& s, const VectorX& q);                // V_eff = V', J
void gradient(const System& s, const VectorX& q, VectorX& g);       // ∇V', n
void hessian(const System& s, const VectorX& q, MatrixX& H);        // ∇∇V', n×n
void mass_matrix(const System& s, const VectorX& q, MatrixX& M);    // M', n×n
VectorX frame_coupling(const System& s, const VectorX& q);          // g', n
double force_scale(const System& s, const VectorX& q);

}  // namespace modal::map_eval
