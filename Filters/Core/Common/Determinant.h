// SPDX-License-Identifier: BSD-3-Clause
#ifndef stmCoreDeterminant_h
#define stmCoreDeterminant_h

// The determinant of the core's small matrices (at most 5 x 5), shared by the mesh checker and
// the orientation of cut pieces (a hot path: one per piece of every cut cell).

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

} // namespace stm

#endif
