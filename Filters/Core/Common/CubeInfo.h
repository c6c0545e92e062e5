// SPDX-License-Identifier: BSD-3-Clause
#ifndef stmCoreCubeInfo_h
#define stmCoreCubeInfo_h

// Compile-time combinatorics of the Dim-cube and of lattice indices, in the spirit of
// deal.II's GeometryInfo<dim>. Every count is derived from Dim so that the algorithms are
// written once for any dimension.

#include <array>
#include <cstdint>
#include <type_traits>
#include <utility>

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

/// Calls visit(point) for the points lower + i * step (i >= 0 per axis) of the box
/// [lower, upper), in lattice order (axis 0 fastest). A visitor that returns bool stops the walk
/// by returning false. Returns false if it was stopped, true otherwise (also for an empty box).
template <int Dim, class Visitor>
bool ForEachLatticePoint(const LatticeIndex<Dim>& lower, const LatticeIndex<Dim>& upper,
  const LatticeIndex<Dim>& step, Visitor&& visit)
{
  for (int axis = 0; axis < Dim; ++axis)
  {
    if (upper[axis] <= lower[axis])
    {
      return true;
    }
  }
  LatticeIndex<Dim> point = lower;
  for (;;)
  {
    const LatticeIndex<Dim>& current = point;
    if constexpr (std::is_same_v<decltype(visit(current)), bool>)
    {
      if (!visit(current))
      {
        return false;
      }
    }
    else
    {
      visit(current);
    }
    int axis = 0;
    for (; axis < Dim; ++axis)
    {
      point[axis] += step[axis];
      if (point[axis] < upper[axis])
      {
        break;
      }
      point[axis] = lower[axis];
    }
    if (axis == Dim)
    {
      return true;
    }
  }
}

/// ForEachLatticePoint with unit steps: every lattice point of [lower, upper).
template <int Dim, class Visitor>
bool ForEachLatticePoint(
  const LatticeIndex<Dim>& lower, const LatticeIndex<Dim>& upper, Visitor&& visit)
{
  LatticeIndex<Dim> unit;
  unit.fill(1);
  return ForEachLatticePoint<Dim>(lower, upper, unit, std::forward<Visitor>(visit));
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
