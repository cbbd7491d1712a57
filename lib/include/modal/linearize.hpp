// modal/linearize.hpp — the linear model about an equilibrium q̄:
//
//   M δq̈ + (D + G) δq̇ + K δq = 0,   M = M(q̄), K = ∇∇V(q̄), D from dampers, G gyroscopic
//
//   modal::LinearModel lin = modal::linearize(sys, equilibrium.q);
//
// Throws NotAnEquilibrium (with the residual, in words) when q̄ is not one.
#pragma once

#include "modal/core.hpp"

#include <string>
#include <vector>

namespace modal {

class NotAnEquilibrium : public NumericalError {
 public:
  using NumericalError::NumericalError;
};

struct LinearModel {
  VectorX q;                             // the equilibrium, n
  std::vector<std::string> coordinates;  // names, n
  MatrixX M;                             // mass, n×n, symmetric
  MatrixX K;                             // stiffness, n×n (symmetric unless circulatory)
  MatrixX D;                             // damping, n×n, symmetric PSD (zero when no dampers)
  MatrixX G;                             // gyroscopic, n×n, skew (zero when absent)
  bool has_damping = false;
  bool has_gyroscopic = false;
  bool circulatory = false;              // K not symmetric (follower loads)
  double residual = 0;                   // relative equilibrium residual at q
  // Steady motion: rates and momenta of ignorable coordinates (maps analyzed
  // through Routh's reduction); empty otherwise.
  std::vector<SteadyRate> steady;

  int size() const { return static_cast<int>(q.size()); }
  // K φ = λ M φ describes the motion completely (no D, G, circulatory part).
  bool symmetric() const { return !has_damping && !has_gyroscopic && !circulatory; }
};

struct LinearizeOptions {
  double tolerance = 1e-8;  // largest relative residual accepted as an equilibrium
};

LinearModel linearize(const System& s, const VectorX& q, const LinearizeOptions& options = {});

}  // namespace modal
