// SPDX-License-Identifier: BSD-3-Clause
#ifndef stmCoreLevelSetProjection_h
#define stmCoreLevelSetProjection_h

// Moving a point onto the level set of a function that can be evaluated anywhere (an implicit
// function, an interpolated gray image): vertex snapping and boundary smoothing use it when the
// function is known beyond the mesh's vertices, so that a moved vertex lies on the true surface
// rather than on the linear interpolant along one edge.

#include <cmath>

namespace stm
{

struct LevelSetProjectionOptions
{
  double IsoValue = 0.0;
  /// Converged when |f - IsoValue| <= Tolerance.
  double Tolerance = 1e-12;
  /// Fails rather than move the point farther than this from where it started.
  double MaxDistance = 1.0;
  int MaxIterations = 20;
};

/// Newton steps along the gradient, x <- x - (f(x) - iso) g / |g|^2, which converge to a point
/// of the level set near the foot of the normal through x. evaluate(const double* x, double*
/// gradient) returns f(x) and writes its gradient. Returns whether it converged within
/// MaxDistance; on failure x is unchanged.
template <int Dim, class Evaluate>
bool ProjectToLevelSet(
  double (&x)[Dim], Evaluate&& evaluate, const LevelSetProjectionOptions& options)
{
  double point[Dim];
  for (int c = 0; c < Dim; ++c)
  {
    point[c] = x[c];
  }
  for (int iteration = 0; iteration <= options.MaxIterations; ++iteration)
  {
    double gradient[Dim];
    const double residual =
      evaluate(static_cast<const double*>(point), gradient) - options.IsoValue;
    if (!std::isfinite(residual))
    {
      return false;
    }
    if (std::abs(residual) <= options.Tolerance)
    {
      for (int c = 0; c < Dim; ++c)
      {
        x[c] = point[c];
      }
      return true;
    }
    if (iteration == options.MaxIterations)
    {
      break;
    }
    double squaredNorm = 0.0;
    for (int c = 0; c < Dim; ++c)
    {
      squaredNorm += gradient[c] * gradient[c];
    }
    if (!(squaredNorm > 0.0) || !std::isfinite(squaredNorm))
    {
      return false;
    }
    double distance = 0.0;
    for (int c = 0; c < Dim; ++c)
    {
      point[c] -= residual * gradient[c] / squaredNorm;
      distance += (point[c] - x[c]) * (point[c] - x[c]);
    }
    if (!(distance <= options.MaxDistance * options.MaxDistance))
    {
      return false;
    }
  }
  return false;
}

} // namespace stm

#endif
