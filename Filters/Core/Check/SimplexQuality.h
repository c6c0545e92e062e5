// SPDX-License-Identifier: BSD-3-Clause
#ifndef stmCoreSimplexQuality_h
#define stmCoreSimplexQuality_h

// Shape measures of one simplex, for the algorithms that decide by element quality (quality
// driven vertex snapping, the move rejection of boundary smoothing). They agree with Verdict
// (vtkMeshQuality) on triangles and tetrahedra, which the filter tests check, and extend to any
// dimension through the Gram matrix M = A^T A of the edge vectors A = [x1 - x0, ..., xd - x0]:
// - condition number: |A W^-1|_F |W A^-1|_F / d, W the regular simplex with unit edges; since
//   W^T W = G = (I + 1 1^T) / 2, it is sqrt(tr(M G^-1) tr(G M^-1)) / d, with no W at all;
// - dihedral angles: the rows of A^-1 are the gradients of the barycentric coordinates 1..d
//   (the gradient of coordinate 0 is minus their sum), and the angle between the facets opposite
//   vertices i and j is acos(-g_i . g_j / (|g_i| |g_j|)); the g_i . g_j are entries of M^-1.

#include "Common/Determinant.h"

#include <cmath>
#include <limits>

namespace stm
{

template <int Dim>
struct SimplexShape
{
  /// det(A): d! times the signed volume; positive for a simplex in VTK's orientation.
  double Determinant = 0.0;
  /// Condition number, 1 for the regular simplex; +infinity unless Determinant > 0.
  double Condition = std::numeric_limits<double>::infinity();
  /// Smallest angle between two facets in degrees (for triangles: the smallest angle); 0 unless
  /// Determinant > 0; 180 for segments, which have no two facets meeting.
  double MinDihedralDegrees = 0.0;
};

/// Measures the simplex with the given Dim + 1 corners of Dim coordinates each.
template <int Dim>
SimplexShape<Dim> MeasureSimplex(const double* const (&corners)[Dim + 1])
{
  static_assert(Dim >= 1 && Dim <= 4, "simplex quality supports dimensions 1 to 4");
  SimplexShape<Dim> shape;
  double edges[Dim][Dim]; // edges[r][c]: coordinate r of edge c, i.e. A
  for (int c = 0; c < Dim; ++c)
  {
    for (int r = 0; r < Dim; ++r)
    {
      edges[r][c] = corners[c + 1][r] - corners[0][r];
    }
  }
  shape.Determinant = stm::Determinant<Dim>(edges);
  if (!(shape.Determinant > 0.0))
  {
    return shape;
  }
  double gram[Dim][Dim];
  for (int i = 0; i < Dim; ++i)
  {
    for (int j = 0; j < Dim; ++j)
    {
      double sum = 0.0;
      for (int r = 0; r < Dim; ++r)
      {
        sum += edges[r][i] * edges[r][j];
      }
      gram[i][j] = sum;
    }
  }
  // M^-1 by Gauss-Jordan on the symmetric positive definite Gram matrix (no pivoting needed).
  double inverse[Dim][Dim];
  double work[Dim][Dim];
  for (int i = 0; i < Dim; ++i)
  {
    for (int j = 0; j < Dim; ++j)
    {
      work[i][j] = gram[i][j];
      inverse[i][j] = i == j ? 1.0 : 0.0;
    }
  }
  for (int p = 0; p < Dim; ++p)
  {
    const double pivot = work[p][p];
    if (!(pivot > 0.0))
    {
      shape.Determinant = 0.0;
      return shape;
    }
    for (int j = 0; j < Dim; ++j)
    {
      work[p][j] /= pivot;
      inverse[p][j] /= pivot;
    }
    for (int i = 0; i < Dim; ++i)
    {
      if (i != p)
      {
        const double factor = work[i][p];
        for (int j = 0; j < Dim; ++j)
        {
          work[i][j] -= factor * work[p][j];
          inverse[i][j] -= factor * inverse[p][j];
        }
      }
    }
  }
  // tr(M G^-1) with G^-1 = 2 (I - 1 1^T / (d + 1)); tr(G M^-1) with G = (I + 1 1^T) / 2.
  double traceM = 0.0, sumM = 0.0, traceInverse = 0.0, sumInverse = 0.0;
  for (int i = 0; i < Dim; ++i)
  {
    traceM += gram[i][i];
    traceInverse += inverse[i][i];
    for (int j = 0; j < Dim; ++j)
    {
      sumM += gram[i][j];
      sumInverse += inverse[i][j];
    }
  }
  const double first = 2.0 * (traceM - sumM / (Dim + 1));
  const double second = 0.5 * (traceInverse + sumInverse);
  shape.Condition = std::sqrt(first * second) / Dim;

  if constexpr (Dim == 1)
  {
    shape.MinDihedralDegrees = 180.0;
  }
  else
  {
    // Inner products of the barycentric gradients g_0..g_d, g_0 = -(g_1 + ... + g_d).
    double products[Dim + 1][Dim + 1];
    for (int i = 0; i < Dim; ++i)
    {
      for (int j = 0; j < Dim; ++j)
      {
        products[i + 1][j + 1] = inverse[i][j];
      }
    }
    products[0][0] = sumInverse;
    for (int j = 0; j < Dim; ++j)
    {
      double column = 0.0;
      for (int i = 0; i < Dim; ++i)
      {
        column += inverse[i][j];
      }
      products[0][j + 1] = products[j + 1][0] = -column;
    }
    double largestCosine = -1.0;
    for (int i = 0; i <= Dim; ++i)
    {
      for (int j = i + 1; j <= Dim; ++j)
      {
        const double cosine = -products[i][j] / std::sqrt(products[i][i] * products[j][j]);
        largestCosine = cosine > largestCosine ? cosine : largestCosine;
      }
    }
    largestCosine = largestCosine > 1.0 ? 1.0 : largestCosine;
    shape.MinDihedralDegrees = std::acos(largestCosine) * (180.0 / 3.14159265358979323846);
  }
  return shape;
}

} // namespace stm

#endif
