// SPDX-License-Identifier: BSD-3-Clause
#ifndef stmCoreCubeInfo_h
#define stmCoreCubeInfo_h

// Compile-time combinatorics of the Dim-cube and of lattice indices, in the spirit of
// deal.II's GeometryInfo<dim>. Every count is derived from Dim so that the algorithms are
// written once for any dimension.

#include <array>
#include <cstdint>

namespace stm
{

constexpr int IntPow(int base, int exponent)
{
  return exponent == 0 ? 1 : base * IntPow(base, exponent - 1);
}

constexpr int Binomial(int n, int k)
{
  return (k < 0 || k > n) ? 0
    : (k == 0 || k == n)  ? 1
                          : Binomial(n - 1, k - 1) + Binomial(n - 1, k);
}

constexpr int Factorial(int n)
{
  return n <= 1 ? 1 : n * Factorial(n - 1);
}

constexpr int PopCount(unsigned v)
{
  int count = 0;
  for (; v != 0; v &= v - 1)
  {
    ++count;
  }
  return count;
}

/// Bit count of a 64-bit word, inline (without -mpopcnt the builtin is a library call).
inline int PopCount64(std::uint64_t v)
{
  v = v - ((v >> 1) & 0x5555555555555555ull);
  v = (v & 0x3333333333333333ull) + ((v >> 2) & 0x3333333333333333ull);
  v = (v + (v >> 4)) & 0x0F0F0F0F0F0F0F0Full;
  return static_cast<int>((v * 0x0101010101010101ull) >> 56);
}

/// Integer position on a Cartesian lattice; axis 0 varies fastest in linear layouts.
template <int Dim>
using LatticeIndex = std::array<std::int64_t, Dim>;

template <int Dim>
struct CubeInfo
{
  static_assert(Dim >= 1 && Dim <= 4, "SpacetreeMesh instantiates dimensions 1 to 4");

  static constexpr int VerticesPerCell = 1 << Dim;
  static constexpr int FacetsPerCell = 2 * Dim;
  /// Neighbours sharing at least a vertex (face, edge and vertex neighbours).
  static constexpr int NeighborDirections = IntPow(3, Dim) - 1;
  /// Edges of the cube: Dim * 2^(Dim-1).
  static constexpr int EdgesPerCell = Dim * (1 << (Dim - 1));
  /// Number of k-dimensional faces of the Dim-cube: C(Dim, k) 2^(Dim-k).
  static constexpr int FacesOfDimension(int k) { return Binomial(Dim, k) * (1 << (Dim - k)); }
  /// Simplices of the Kuhn (Freudenthal) subdivision of the cube.
  static constexpr int KuhnSimplicesPerCell = Factorial(Dim);
  /// Vertices of a Dim-simplex.
  static constexpr int VerticesPerSimplex = Dim + 1;
  /// Simplices of the checkerboard template (2 triangles, 5 tetrahedra); defined for Dim <= 3.
  static constexpr int CheckerboardSimplicesPerCell = Dim == 1 ? 1
    : Dim == 2                                                 ? 2
    : Dim == 3                                                 ? 5
                                                               : 0;
};

/// Linear index of a lattice index inside a box of the given dimensions (axis 0 fastest).
template <int Dim>
inline std::int64_t LinearIndex(const LatticeIndex<Dim>& index, const LatticeIndex<Dim>& dims)
{
  std::int64_t linear = 0;
  for (int axis = Dim - 1; axis >= 0; --axis)
  {
    linear = linear * dims[axis] + index[axis];
  }
  return linear;
}

template <int Dim>
inline std::int64_t NumberOfLatticeCells(const LatticeIndex<Dim>& dims)
{
  std::int64_t count = 1;
  for (int axis = 0; axis < Dim; ++axis)
  {
    count *= dims[axis];
  }
  return count;
}

} // namespace stm

#endif
