// SPDX-License-Identifier: BSD-3-Clause
#ifndef stmCoreDeterminant_h
#define stmCoreDeterminant_h

// The determinant of the core's small matrices (at most 5 x 5), shared by the mesh checker and
// the orientation of cut pieces in 4D, and the exact orientation of integer simplices (the
// tessellation's, and the table of cut pieces' orientations up to 3D).

#include <array>
#include <cstdint>
#include <utility>

namespace stm
{

/// Determinant by cofactor expansion along the first row: the Leibniz sum of products, grouped,
/// so exact for the small dyadic entries of lattice meshes; sizes are compile-time, so the
/// expansion unrolls without the permutation walk of the plain formula.
template <int K>
double Determinant(const double (&m)[K][K])
{
  if constexpr (K == 1)
  {
    return m[0][0];
  }
  else
  {
    double sum = 0.0;
    double minor[K - 1][K - 1];
    for (int column = 0; column < K; ++column)
    {
      for (int row = 1; row < K; ++row)
      {
        for (int c = 0, target = 0; c < K; ++c)
        {
          if (c != column)
          {
            minor[row - 1][target++] = m[row][c];
          }
        }
      }
      const double term = m[0][column] * Determinant<K - 1>(minor);
      sum += column % 2 == 0 ? term : -term;
    }
    return sum;
  }
}

/// Exact orientation of a simplex given by Dim+1 integer points (Point: Dim integer coordinates
/// by operator[], such as LatticeIndex<Dim>): the determinant of the edge vectors from the first
/// point. constexpr up to 3D, for compile-time tables (PieceOrientation).
template <int Dim, class Point>
constexpr std::int64_t SimplexDeterminant(const Point* points)
{
  std::int64_t m[Dim][Dim] = {};
  for (int row = 0; row < Dim; ++row)
  {
    for (int col = 0; col < Dim; ++col)
    {
      m[row][col] = points[row + 1][col] - points[0][col];
    }
  }
  if constexpr (Dim == 1)
  {
    return m[0][0];
  }
  else if constexpr (Dim == 2)
  {
    return m[0][0] * m[1][1] - m[0][1] * m[1][0];
  }
  else if constexpr (Dim == 3)
  {
    return m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) -
      m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0]) +
      m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
  }
  else
  {
    // Bareiss fraction-free elimination: exact for integer matrices.
    std::int64_t sign = 1;
    std::int64_t previous = 1;
    for (int k = 0; k < Dim - 1; ++k)
    {
      if (m[k][k] == 0)
      {
        int swap = k + 1;
        while (swap < Dim && m[swap][k] == 0)
        {
          ++swap;
        }
        if (swap == Dim)
        {
          return 0;
        }
        std::swap(m[k], m[swap]);
        sign = -sign;
      }
      for (int i = k + 1; i < Dim; ++i)
      {
        for (int j = k + 1; j < Dim; ++j)
        {
          m[i][j] = (m[i][j] * m[k][k] - m[i][k] * m[k][j]) / previous;
        }
      }
      previous = m[k][k];
    }
    return sign * m[Dim - 1][Dim - 1];
  }
}

} // namespace stm

#endif
