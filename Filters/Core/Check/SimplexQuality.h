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

#include <algorithm>
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

/// SimplexShape with the cosine of the smallest dihedral angle instead of the angle: what the
/// hot loops compare (against cos(bound)), since acos costs as much as the rest of a tetrahedron.
struct SimplexCosines
{
  double Determinant = 0.0;
  double Condition = std::numeric_limits<double>::infinity();
  /// The largest cosine of an angle between two facets, in [-1, 1]; 1 unless Determinant > 0;
  /// -1 for segments.
  double LargestDihedralCosine = 1.0;
};

/// The angle in degrees of a cosine from SimplexCosines: monotone (non-increasing), so the
/// smallest angle of a set of simplices is the angle of their largest cosine.
inline double DihedralDegrees(double cosine)
{
  return std::acos(cosine > 1.0 ? 1.0 : cosine) * (180.0 / 3.14159265358979323846);
}

namespace detail
{
/// The closed-form terms of a triangle or tetrahedron (see MeasureSimplexCosines).
template <int Dim>
struct FacetTerms
{
  double Determinant;
  double EdgeSum;            // sum of the squared edge lengths
  double LongestEdgeSquared; // the largest squared edge length
  // Tetrahedra: the squared edges x1 - x0, x2 - x0, x3 - x0, x2 - x1, x3 - x1, x3 - x2 (for
  // triangles, Squared holds them).
  double EdgeSquared[Dim == 3 ? 6 : 1];
  double Normals[Dim + 1][Dim];
  double Squared[Dim + 1]; // |n_i|^2
  double NormalSum;
};

template <int Dim>
void ComputeFacetTerms(const double* const (&corners)[Dim + 1], FacetTerms<Dim>& t)
{
  static_assert(Dim == 2 || Dim == 3, "closed forms for triangles and tetrahedra only");
  double edges[Dim][Dim]; // edges[r][c]: coordinate r of edge c, i.e. A
  for (int c = 0; c < Dim; ++c)
  {
    for (int r = 0; r < Dim; ++r)
    {
      edges[r][c] = corners[c + 1][r] - corners[0][r];
    }
  }
  auto dot = [](const double* u, const double* v)
  {
    double sum = 0.0;
    for (int r = 0; r < Dim; ++r)
    {
      sum += u[r] * v[r];
    }
    return sum;
  };
  if constexpr (Dim == 2)
  {
    // In the plane n_i is the opposite edge turned by 90 degrees; only inner products matter,
    // so the edges x2 - x1, x0 - x2, x1 - x0 themselves (they sum to zero as the n_i must).
    for (int r = 0; r < 2; ++r)
    {
      t.Normals[0][r] = corners[2][r] - corners[1][r];
      t.Normals[1][r] = corners[0][r] - corners[2][r];
      t.Normals[2][r] = corners[1][r] - corners[0][r];
    }
    for (int i = 0; i < 3; ++i)
    {
      t.Squared[i] = dot(t.Normals[i], t.Normals[i]);
    }
    t.EdgeSum = t.Squared[0] + t.Squared[1] + t.Squared[2];
    t.LongestEdgeSquared = std::max(t.Squared[0], std::max(t.Squared[1], t.Squared[2]));
    t.NormalSum = t.EdgeSum;
    // Determinant<2>'s expansion, term for term (the same bits).
    t.Determinant = edges[0][0] * edges[1][1] - edges[0][1] * edges[1][0];
  }
  else
  {
    double e[6][3]; // x1 - x0, x2 - x0, x3 - x0, x2 - x1, x3 - x1, x3 - x2
    for (int r = 0; r < 3; ++r)
    {
      e[0][r] = edges[r][0];
      e[1][r] = edges[r][1];
      e[2][r] = edges[r][2];
      e[3][r] = corners[2][r] - corners[1][r];
      e[4][r] = corners[3][r] - corners[1][r];
      e[5][r] = corners[3][r] - corners[2][r];
    }
    auto cross = [](const double* u, const double* v, double* w)
    {
      w[0] = u[1] * v[2] - u[2] * v[1];
      w[1] = u[2] * v[0] - u[0] * v[2];
      w[2] = u[0] * v[1] - u[1] * v[0];
    };
    // n_0 from the opposite face's own edges rather than as -(n_1 + n_2 + n_3), which cancels
    // on needles.
    cross(e[4], e[3], t.Normals[0]);
    cross(e[1], e[2], t.Normals[1]);
    cross(e[2], e[0], t.Normals[2]);
    cross(e[0], e[1], t.Normals[3]);
    t.EdgeSum = 0.0;
    t.LongestEdgeSquared = 0.0;
    for (int k = 0; k < 6; ++k)
    {
      const double squared = dot(e[k], e[k]);
      t.EdgeSquared[k] = squared;
      t.EdgeSum += squared;
      t.LongestEdgeSquared = std::max(t.LongestEdgeSquared, squared);
    }
    for (int i = 0; i < 4; ++i)
    {
      t.Squared[i] = dot(t.Normals[i], t.Normals[i]);
    }
    t.NormalSum = t.Squared[0] + t.Squared[1] + t.Squared[2] + t.Squared[3];
    // Determinant<3>'s cofactor expansion along the first row, term for term: its minors are
    // the first coordinates of n_1, -n_2 and n_3, so this is the same bits (exact on lattices,
    // like the rest of the core), without the call the recursive template costs.
    t.Determinant =
      e[0][0] * t.Normals[1][0] + e[1][0] * t.Normals[2][0] + e[2][0] * t.Normals[3][0];
  }
}

/// The condition number is sqrt(EdgeSum NormalSum) / (ConditionScale D).
template <int Dim>
double ConditionScale()
{
  return Dim == 2 ? 2.0 * std::sqrt(3.0) : 6.0;
}
} // namespace detail

/// Measures the simplex with the given Dim + 1 corners of Dim coordinates each. Triangles and
/// tetrahedra, the hot cases, use closed forms of the Gram matrix expressions (header comment):
/// with the facet normals n_i of length (d - 1)! times the facet measure (the rows of
/// det(A) A^-1, so n_0 = -(n_1 + ... + n_d)) and D = det(A),
///   tr(M G^-1) = 2 sum|e|^2 / (d + 1) over the edges e,  tr(G M^-1) = sum|n_i|^2 / (2 D^2),
/// hence the condition number sqrt(sum|e|^2 sum|n_i|^2) / (6 D) for tetrahedra and
/// sum|e|^2 / (2 sqrt(3) D) for triangles (where the n_i are the turned edges), and the
/// dihedral cosines -n_i . n_j / (|n_i| |n_j|). Segments and 4-simplices keep the generic Gram
/// matrix inverse.
template <int Dim>
SimplexCosines MeasureSimplexCosines(const double* const (&corners)[Dim + 1])
{
  static_assert(Dim >= 1 && Dim <= 4, "simplex quality supports dimensions 1 to 4");
  SimplexCosines shape;
  if constexpr (Dim == 2 || Dim == 3)
  {
    detail::FacetTerms<Dim> t;
    detail::ComputeFacetTerms<Dim>(corners, t);
    shape.Determinant = t.Determinant;
    if (!(t.Determinant > 0.0))
    {
      return shape;
    }
    shape.Condition =
      std::sqrt(t.EdgeSum * t.NormalSum) / (detail::ConditionScale<Dim>() * t.Determinant);
    double inverse[Dim + 1];
    for (int i = 0; i <= Dim; ++i)
    {
      inverse[i] = 1.0 / std::sqrt(t.Squared[i]);
    }
    double largest = -1.0;
    for (int i = 0; i <= Dim; ++i)
    {
      for (int j = i + 1; j <= Dim; ++j)
      {
        double product = 0.0;
        for (int r = 0; r < Dim; ++r)
        {
          product += t.Normals[i][r] * t.Normals[j][r];
        }
        const double cosine = -product * (inverse[i] * inverse[j]);
        largest = cosine > largest ? cosine : largest;
      }
    }
    shape.LargestDihedralCosine = largest > 1.0 ? 1.0 : largest;
    return shape;
  }
  else
  {
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
      shape.LargestDihedralCosine = -1.0;
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
      shape.LargestDihedralCosine = largestCosine > 1.0 ? 1.0 : largestCosine;
    }
    return shape;
  }
}

namespace detail
{
/// SimplexSurelyWithin on computed terms.
template <int Dim>
bool TermsSurelyWithin(const FacetTerms<Dim>& t, double maxCondition, double maxCosine)
{
  constexpr double Margin = 1.0 - 1e-12;
  if (!(t.Determinant > 0.0))
  {
    return false;
  }
  const double scaled = ConditionScale<Dim>() * t.Determinant * maxCondition;
  if (!(t.EdgeSum * t.NormalSum <= scaled * scaled * Margin))
  {
    return false;
  }
  // -n_i . n_j / (|n_i| |n_j|) <= c: true for n_i . n_j >= 0, else (n_i . n_j)^2 <= c^2 s_i s_j.
  const double squaredCosine = maxCosine * maxCosine * Margin;
  for (int i = 0; i <= Dim; ++i)
  {
    for (int j = i + 1; j <= Dim; ++j)
    {
      double product = 0.0;
      for (int r = 0; r < Dim; ++r)
      {
        product += t.Normals[i][r] * t.Normals[j][r];
      }
      if (product < 0.0 && !(product * product <= squaredCosine * t.Squared[i] * t.Squared[j]))
      {
        return false;
      }
    }
  }
  return true;
}
} // namespace detail

/// Whether the simplex is surely within the bounds: Determinant > 0, Condition <= maxCondition
/// and LargestDihedralCosine <= maxCosine (maxCosine >= 0), decided for triangles and
/// tetrahedra by squared comparisons, without the square roots and divisions of the measure,
/// and with a relative margin of 1e-12 that covers their rounding: true implies that
/// MeasureSimplexCosines's figures are within the bounds. False decides nothing (always so for
/// segments and 4-simplices): measure.
template <int Dim>
bool SimplexSurelyWithin(
  const double* const (&corners)[Dim + 1], double maxCondition, double maxCosine)
{
  if constexpr (Dim == 2 || Dim == 3)
  {
    if (!(maxCosine >= 0.0))
    {
      return false;
    }
    detail::FacetTerms<Dim> t;
    detail::ComputeFacetTerms<Dim>(corners, t);
    return detail::TermsSurelyWithin<Dim>(t, maxCondition, maxCosine);
  }
  else
  {
    (void)corners;
    (void)maxCondition;
    (void)maxCosine;
    return false;
  }
}

/// SimplexSurelyWithin with a slack: -1 where SimplexSurelyWithin is false, else a distance
/// R >= 0 such that SimplexSurelyWithin stays true after any moves of the corners whose lengths
/// add up to at most R. A smoother that moves one corner at a time keeps a budget per cell
/// from it and skips the measure while the moves fit in the budget (the decisions stay those of
/// the measure, so the result does not change).
///
/// The bounds, for corner moves of lengths r_i with sum R (the measures are affine in each
/// corner, so the first-order terms take one corner at a time, and the functions of the r_i
/// bounded below are convex, so their largest value on {r_i >= 0, sum r_i <= R} is at a corner
/// of that simplex: one corner moved by all of R):
/// - the edges: |e'_ij - e_ij| <= r_i + r_j, and sum over the edges of (r_i + r_j)^2 <= d R^2
///   (each corner is on d edges), so sqrt(sum|e'|^2) <= sqrt(sum|e|^2) + sqrt(d) R;
/// - the facet normals: a triangle's are its turned edges, which change by at most R; a
///   tetrahedron's face (a, b, c) has n = a x b + b x c + c x a, so n changes by
///   da x (b - c) + db x (c - a) + dc x (a - b) + da x db + db x dc + dc x da, at most
///   eps_k = L_k R + R^2 / 3 with L_k the face's longest edge; each normal turns by at most
///   asin(eps_k / |n_k|), and the dihedral angle between facets i and j shrinks by at most the
///   turns of n_i and n_j together (its lead over the bound is shared between the two, below);
///   over the facets, sum|n'_k - n_k|^2 <= (L + R / 3)^2 sum_k (R - r_k)^2 <= d (L + R / 3)^2 R^2
///   (L the longest edge; 2 R^2 for triangles);
/// - the determinant, affine in each corner with gradient n_i (|n_i| the facet's measure
///   times (d - 1)!) and multilinear in the corners' moves: by at most R max|n_i| + R^2 / 3 for
///   triangles and R max|n_i| + 3/8 L R^2 + R^3 / 16 for tetrahedra (the products of two and
///   three moves, with at most L between the remaining corners).
/// The slack keeps a relative margin of 1e-9 to the bounds, far above the 1e-12 with which
/// SimplexSurelyWithin covers its rounding.
///
/// Until 2026-12-05 the bounds took each edge as changing by R on its own: sqrt(#edges) R for
/// the edges, (|u| + |v|) R + R^2 for a face's normal (u, v its two shortest edges) and
/// R (|n1| + |n2| + |n3|) + 3 L R^2 + R^3 for the determinant, and every normal could turn by
/// half the smallest angle's lead. The slacks of the regular triangle and tetrahedron and of
/// the checkerboard's corner tetrahedron grew from 0.223, 0.134 and 0.135 to 0.354, 0.322 and
/// 0.260; the smoother computes 38 % fewer slacks for the same moves (docs/performance.md).
template <int Dim>
double SimplexSlack(const double* const (&corners)[Dim + 1], double maxCondition, double maxCosine)
{
  if constexpr (Dim == 2 || Dim == 3)
  {
    if (!(maxCosine >= 0.0 && maxCosine < 1.0))
    {
      return -1.0;
    }
    detail::FacetTerms<Dim> t;
    detail::ComputeFacetTerms<Dim>(corners, t);
    if (!detail::TermsSurelyWithin<Dim>(t, maxCondition, maxCosine))
    {
      return -1.0;
    }
    constexpr double Margin = 1e-9;
    double lengths[Dim + 1];
    for (int i = 0; i <= Dim; ++i)
    {
      lengths[i] = std::sqrt(t.Squared[i]);
    }
    // How fast each facet's normal turns as the corners move, to first order: eps_k / |n_k| per
    // unit of R, with eps_k = R for triangles and L_k R + R^2 / 3 for tetrahedra (L_k the face's
    // longest edge).
    constexpr int Edges[4][3] = { { 3, 4, 5 }, { 1, 2, 5 }, { 0, 2, 4 }, { 0, 1, 3 } };
    double faceLongest[Dim + 1], rates[Dim + 1];
    for (int k = 0; k <= Dim; ++k)
    {
      if constexpr (Dim == 3)
      {
        faceLongest[k] = std::sqrt(std::max(t.EdgeSquared[Edges[k][0]],
          std::max(t.EdgeSquared[Edges[k][1]], t.EdgeSquared[Edges[k][2]])));
      }
      else
      {
        faceLongest[k] = 1.0;
      }
      rates[k] = faceLongest[k] / lengths[k];
    }
    // Each dihedral angle's lead over the bound, d_ij = acos(c_ij) - acos(maxCosine) in (0, pi),
    // as sin d and cos d. The angle between facets i and j shrinks by at most the turns of n_i
    // and n_j, so the lead is shared between them in proportion to their rates, w_i + w_j = 1,
    // and facet k's normal may turn by the smallest of its shares, each at most pi / 2: w d
    // with sin(w d) >= w sin d (sine is concave on [0, pi]), or for d beyond pi / 2 the
    // smaller w pi / 2 with sin(w pi / 2) >= w.
    const double boundSine = std::sqrt(1.0 - maxCosine * maxCosine);
    double turnSines[Dim + 1]; // per facet, the sine of the largest turn of its normal
    std::fill(turnSines, turnSines + Dim + 1, 1.0);
    for (int i = 0; i <= Dim; ++i)
    {
      for (int j = i + 1; j <= Dim; ++j)
      {
        double product = 0.0;
        for (int r = 0; r < Dim; ++r)
        {
          product += t.Normals[i][r] * t.Normals[j][r];
        }
        const double cosine = std::min(1.0, -product / (lengths[i] * lengths[j]) + Margin);
        const double sine = std::sqrt(1.0 - cosine * cosine);
        const double leadSine = sine * maxCosine - cosine * boundSine - Margin;
        const double leadCosine = cosine * maxCosine + sine * boundSine;
        if (!(leadSine > 0.0))
        {
          return 0.0;
        }
        const double lead = leadCosine >= 0.0 ? leadSine : 1.0;
        const double share = rates[i] / (rates[i] + rates[j]);
        turnSines[i] = std::min(turnSines[i], share * lead);
        turnSines[j] = std::min(turnSines[j], (1.0 - share) * lead);
      }
    }
    // Per facet k the largest R with eps_k <= |n_k| sin(turn_k).
    double slack = std::numeric_limits<double>::infinity();
    for (int k = 0; k <= Dim; ++k)
    {
      const double turn = lengths[k] * turnSines[k]; // the largest change of n_k
      if constexpr (Dim == 2)
      {
        slack = std::min(slack, turn);
      }
      else
      {
        const double longestOfFace = faceLongest[k];
        slack = std::min(slack,
          2.0 * turn /
            (longestOfFace + std::sqrt(longestOfFace * longestOfFace + turn * (4.0 / 3.0))));
      }
    }
    const double longest = std::sqrt(t.LongestEdgeSquared);
    // The condition number: the bound grows with R; the largest R in [0, slack] that keeps it,
    // from the angle's slack, found by regula falsi (below).
    const double edgeRoot = std::sqrt(t.EdgeSum), normalRoot = std::sqrt(t.NormalSum);
    const double limit = detail::ConditionScale<Dim>() * maxCondition * (1.0 - Margin);
    double largestNormal = 0.0; // the determinant's largest gradient
    for (int i = 0; i <= Dim; ++i)
    {
      largestNormal = std::max(largestNormal, lengths[i]);
    }
    // At a distance r: limit det(r) - the product of the bounds of the edge and normal sums,
    // which must be >= 0 with det(r) > 0. It is concave in r (the product of the growing bounds
    // is convex, the determinant's bound concave).
    struct Bound
    {
      double Determinant;
      double Margin;
      bool Keeps() const { return this->Determinant > 0.0 && this->Margin >= 0.0; }
    };
    auto bound = [&](double r)
    {
      const double rootOfDim = Dim == 2 ? 1.4142135623730951 : 1.7320508075688772;
      const double normalChange = Dim == 2 ? rootOfDim * r : rootOfDim * (longest + r / 3.0) * r;
      const double determinant = Dim == 2
        ? t.Determinant - (largestNormal + r / 3.0) * r
        : t.Determinant - (largestNormal + (0.375 * longest + r / 16.0) * r) * r;
      return Bound{ determinant,
        limit * determinant - (edgeRoot + rootOfDim * r) * (normalRoot + normalChange) };
    };
    const Bound atSlack = bound(slack);
    if (!atSlack.Keeps())
    {
      // Regula falsi from below: on a concave margin the chord's zero between a point where it
      // is positive and one where it is not never passes the root.
      double low = 0.0, high = slack, lowMargin = bound(low).Margin, highMargin = atSlack.Margin;
      for (int step = 0; step < 4 && lowMargin > 0.0 && highMargin < lowMargin; ++step)
      {
        const double middle = low + lowMargin * (high - low) / (lowMargin - highMargin);
        const Bound atMiddle = bound(middle);
        if (atMiddle.Keeps())
        {
          low = middle;
          lowMargin = atMiddle.Margin;
        }
        else
        {
          high = middle;
          highMargin = atMiddle.Margin;
        }
      }
      slack = low;
    }
    return slack * (1.0 - 1e-6);
  }
  else
  {
    (void)corners;
    (void)maxCondition;
    (void)maxCosine;
    return -1.0;
  }
}

/// MeasureSimplexCosines's Condition alone (the same bits): for the callers that rank simplices
/// by condition number only, without the dihedral cosines' square roots.
template <int Dim>
double SimplexCondition(const double* const (&corners)[Dim + 1])
{
  if constexpr (Dim == 2 || Dim == 3)
  {
    detail::FacetTerms<Dim> t;
    detail::ComputeFacetTerms<Dim>(corners, t);
    if (!(t.Determinant > 0.0))
    {
      return std::numeric_limits<double>::infinity();
    }
    return std::sqrt(t.EdgeSum * t.NormalSum) / (detail::ConditionScale<Dim>() * t.Determinant);
  }
  else
  {
    return MeasureSimplexCosines<Dim>(corners).Condition;
  }
}

/// Measures the simplex with the given Dim + 1 corners of Dim coordinates each.
template <int Dim>
SimplexShape<Dim> MeasureSimplex(const double* const (&corners)[Dim + 1])
{
  const SimplexCosines cosines = MeasureSimplexCosines<Dim>(corners);
  SimplexShape<Dim> shape;
  shape.Determinant = cosines.Determinant;
  if (!(cosines.Determinant > 0.0))
  {
    return shape;
  }
  shape.Condition = cosines.Condition;
  shape.MinDihedralDegrees = Dim == 1 ? 180.0 : DihedralDegrees(cosines.LargestDihedralCosine);
  return shape;
}

} // namespace stm

#endif
