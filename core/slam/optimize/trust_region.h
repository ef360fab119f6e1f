// The settings and the outcome of the Levenberg-Marquardt (trust region) loop that the dedicated
// solvers share: the pose-only solver (pose_solver.h) and the bundle solver (bundle_solver.h).
#pragma once

#include <string>

namespace dygslam {

struct TrustRegionOptions {
  int max_iterations = 10;
  double initial_trust_radius = 1e4;
  double function_tolerance = 1e-6;
  double gradient_tolerance = 1e-10;
  double parameter_tolerance = 1e-8;

 protected:
  // Throws InvalidOptions naming `iterations_key` (the settings key of max_iterations, which must
  // be >= `min_iterations`, 0 or 1) or `name`.<field> for the others.
  void CheckFields(const std::string& name, const std::string& iterations_key,
                   int min_iterations) const;
};

struct TrustRegionSummary {
  int iterations = 0;  // steps tried (accepted or not)
  int successful_iterations = 0;
  double initial_cost = 0;  // 0.5 sum rho(|r|^2)
  double final_cost = 0;
  bool aborted = false;  // stopped from outside (bundle solver's abort flag)
};

}  // namespace dygslam
