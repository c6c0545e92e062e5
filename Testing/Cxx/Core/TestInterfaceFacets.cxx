// SPDX-License-Identifier: BSD-3-Clause
// Interface extraction in 2D and 3D on the tessellation of a label image where three (2D) or
// four (3D) materials meet inside a background border: the measure of the facets of every
// material pair equals that of the voxel faces between them, every material's facets bound it
// as a closed oriented surface with normals pointing out of the cell written from, the outer
// boundary without the background cells, and the same facets on any number of threads; 1D and
// 4D on small cases.

#include "CoreTestUtilities.h"

#include "Surface/InterfaceFacets.h"

#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <utility>
#include <vector>

namespace
{
using namespace stmtest;
using Pair = std::pair<std::int64_t, std::int64_t>;

/// In a border of background (when `border`), material 1 for x < s, 2 for x >= s and y < s,
/// 3 for x, y >= s (3D: z < s, and 4 for z >= s), s = extent / 2.
template <int D>
LabelImage<D> Junctions(std::int64_t extent, bool border)
{
  const std::int64_t s = extent / 2;
  LabelImage<D> image(UniformExtents<D>(extent));
  ForEachIndex<D>(image.GetDimensions(),
    [&](const stm::LatticeIndex<D>& voxel)
    {
      bool onBorder = false;
      for (int axis = 0; axis < D; ++axis)
      {
        onBorder = onBorder || voxel[axis] == 0 || voxel[axis] == extent - 1;
      }
      stm::MaterialIndex material = voxel[0] < s ? 1 : voxel[1] < s ? 2 : 3;
      if (D == 3 && material == 3 && voxel[D - 1] >= s)
      {
        material = 4;
      }
      image.Set(voxel, border && onBorder ? 0 : material);
    });
  return image;
}

/// Voxel faces per material pair (smaller first; the outside is -1, after the voxel's label),
/// without the outer faces of background voxels.
template <int D>
std::map<Pair, std::int64_t> VoxelFaces(const LabelImage<D>& image)
{
  std::map<Pair, std::int64_t> faces;
  ForEachIndex<D>(image.GetDimensions(),
    [&](const stm::LatticeIndex<D>& voxel)
    {
      const std::int64_t own = image.At(voxel);
      for (int axis = 0; axis < D; ++axis)
      {
        for (const int step : { -1, 1 })
        {
          stm::LatticeIndex<D> next = voxel;
          next[axis] += step;
          if (!image.Contains(next))
          {
            faces[{ own, -1 }] += own == 0 ? 0 : 1;
          }
          else if (step == 1 && image.At(next) != own)
          {
            const std::int64_t other = image.At(next);
            faces[{ std::min(own, other), std::max(own, other) }] += 1;
          }
        }
      }
    });
  for (auto entry = faces.begin(); entry != faces.end();)
  {
    entry = entry->second == 0 ? faces.erase(entry) : std::next(entry);
  }
  return faces;
}

template <int D>
double FacetMeasure(const std::vector<double>& points, const std::int64_t* ids)
{
  const double* a = points.data() + ids[0] * D;
  const double* b = points.data() + ids[1] * D;
  if (D == 2)
  {
    return std::hypot(b[0] - a[0], b[1] - a[1]);
  }
  const double* c = points.data() + ids[2] * D;
  const double u[3] = { b[0] - a[0], b[1] - a[1], b[2] - a[2] };
  const double v[3] = { c[0] - a[0], c[1] - a[1], c[2] - a[2] };
  const double n[3] = { u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2],
    u[0] * v[1] - u[1] * v[0] };
  return 0.5 * std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
}

/// The facet's normal (3D: the cross product; 2D: the segment turned clockwise) dotted with the
/// direction from the written cell's centroid to the facet's.
template <int D>
double OutwardProduct(const std::vector<double>& points, const std::int64_t* facet,
  const std::vector<std::int64_t>& cells, std::int64_t cell)
{
  double normal[D], facetCentre[D] = {}, cellCentre[D] = {};
  const double* a = points.data() + facet[0] * D;
  const double* b = points.data() + facet[1] * D;
  if (D == 2)
  {
    normal[0] = b[1] - a[1];
    normal[1] = -(b[0] - a[0]);
  }
  else
  {
    const double* c = points.data() + facet[D - 1] * D;
    const double u[3] = { b[0] - a[0], b[1] - a[1], b[2] - a[2] };
    const double v[3] = { c[0] - a[0], c[1] - a[1], c[2] - a[2] };
    normal[0] = u[1] * v[2] - u[2] * v[1];
    normal[1] = u[2] * v[0] - u[0] * v[2];
    normal[D - 1] = u[0] * v[1] - u[1] * v[0];
  }
  for (int k = 0; k < D; ++k)
  {
    for (int axis = 0; axis < D; ++axis)
    {
      facetCentre[axis] += points[facet[k] * D + axis] / D;
    }
  }
  for (int k = 0; k <= D; ++k)
  {
    for (int axis = 0; axis < D; ++axis)
    {
      cellCentre[axis] += points[cells[cell * (D + 1) + k] * D + axis] / (D + 1);
    }
  }
  double product = 0.0;
  for (int axis = 0; axis < D; ++axis)
  {
    product += normal[axis] * (facetCentre[axis] - cellCentre[axis]);
  }
  return product;
}

template <class T>
class InterfaceFacetsTest : public ::testing::Test
{
};
using FacetDimensions = ::testing::Types<Dim<2>, Dim<3>>;
TYPED_TEST_SUITE(InterfaceFacetsTest, FacetDimensions);

TYPED_TEST(InterfaceFacetsTest, MatchVoxelFacesAndCloseEveryMaterial)
{
  constexpr int D = TypeParam::value;
  for (const bool border : { true, false })
  {
    SCOPED_TRACE(border ? "background border" : "no background");
    const LabelImage<D> image = Junctions<D>(D == 2 ? 12 : 8, border);
    stm::SequentialExecutor executor;
    stm::Spacetree<D> tree;
    ASSERT_TRUE(BuildTree<D>(image, 4, 1, false, executor, tree).IsOk());
    stm::SpacetreeTessellationOptions tessellation;
    tessellation.IncludeBackground = true;
    SimplicialMesh<D> mesh;
    ASSERT_TRUE(TessellateTree<D>(tree, tessellation, executor, mesh).IsOk());
    const std::vector<double> points = mesh.Coordinates();
    const std::vector<std::int64_t> materials = mesh.MaterialsAsInt64();
    stm::InterfaceFacets<D> facets;
    ASSERT_TRUE(stm::ExtractInterfaceFacets<D>(points.data(), mesh.GetNumberOfPoints(),
      mesh.Connectivity.data(), mesh.GetNumberOfSimplices(), materials.data(),
      stm::InterfaceFacetOptions(), executor, facets)
                  .IsOk());

    // Per pair, the facets measure what the voxel faces do (unit faces).
    std::map<Pair, double> measured;
    for (std::int64_t f = 0; f < facets.GetNumberOfFacets(); ++f)
    {
      const std::int64_t a = facets.Labels[2 * f], b = facets.Labels[2 * f + 1];
      EXPECT_TRUE(b == -1 ? a != 0 : a < b) << "facet " << f;
      const Pair key = b == -1 ? Pair{ a, b } : Pair{ std::min(a, b), std::max(a, b) };
      measured[key] += FacetMeasure<D>(points, facets.Connectivity.data() + f * D);
      // The normal points out of the cell it was written from, whose material is Labels[0].
      EXPECT_EQ(materials[facets.Cells[f]], a);
      EXPECT_GT(OutwardProduct<D>(
                  points, facets.Connectivity.data() + f * D, mesh.Connectivity, facets.Cells[f]),
        0.0)
        << "facet " << f;
    }
    const std::map<Pair, std::int64_t> expected = VoxelFaces<D>(image);
    ASSERT_EQ(measured.size(), expected.size());
    for (const auto& entry : expected)
    {
      EXPECT_NEAR(measured[entry.first], static_cast<double>(entry.second), 1e-9)
        << "pair " << entry.first.first << ", " << entry.first.second;
    }

    // Every material's facets, turned out of it, are closed: each (D - 2)-face is crossed as
    // often in one direction as in the other.
    for (std::int64_t m = border ? 0 : 1; m <= (D == 2 ? 3 : 4); ++m)
    {
      std::map<Pair, int> directed;
      for (std::int64_t f = 0; f < facets.GetNumberOfFacets(); ++f)
      {
        const bool out = facets.Labels[2 * f] == m;
        if (!out && facets.Labels[2 * f + 1] != m)
        {
          continue;
        }
        const std::int64_t* ids = facets.Connectivity.data() + f * D;
        for (int k = 0; k < D; ++k)
        {
          std::int64_t from = ids[k], to = ids[(k + 1) % D];
          if (D == 2 && k == 1)
          {
            break; // a segment: one directed pair
          }
          if (!out)
          {
            std::swap(from, to);
          }
          directed[{ from, to }] += 1;
        }
      }
      if (m == 0 && border)
      {
        // The background's outer facets are not written: its facets bound it only inside.
        continue;
      }
      std::int64_t open = 0;
      for (const auto& entry : directed)
      {
        if (D == 3)
        {
          const auto reverse = directed.find({ entry.first.second, entry.first.first });
          open += reverse == directed.end() || reverse->second != entry.second ? 1 : 0;
        }
      }
      if (D == 2)
      {
        std::map<std::int64_t, int> balance;
        for (const auto& entry : directed)
        {
          balance[entry.first.first] += entry.second;
          balance[entry.first.second] -= entry.second;
        }
        for (const auto& entry : balance)
        {
          open += entry.second != 0 ? 1 : 0;
        }
      }
      EXPECT_EQ(open, 0) << "material " << m;
    }

    // The same facets on three threads; none without the outer boundary but interfaces.
    stm::ThreadPoolExecutor threads(3);
    stm::InterfaceFacets<D> threaded;
    ASSERT_TRUE(stm::ExtractInterfaceFacets<D>(points.data(), mesh.GetNumberOfPoints(),
      mesh.Connectivity.data(), mesh.GetNumberOfSimplices(), materials.data(),
      stm::InterfaceFacetOptions(), threads, threaded)
                  .IsOk());
    EXPECT_EQ(threaded.Connectivity, facets.Connectivity);
    EXPECT_EQ(threaded.Labels, facets.Labels);
    stm::InterfaceFacetOptions inner;
    inner.IncludeOuterBoundary = false;
    stm::InterfaceFacets<D> interfaces;
    ASSERT_TRUE(stm::ExtractInterfaceFacets<D>(points.data(), mesh.GetNumberOfPoints(),
      mesh.Connectivity.data(), mesh.GetNumberOfSimplices(), materials.data(), inner, executor,
      interfaces)
                  .IsOk());
    std::int64_t outer = 0;
    for (std::int64_t f = 0; f < facets.GetNumberOfFacets(); ++f)
    {
      outer += facets.Labels[2 * f + 1] == -1 ? 1 : 0;
    }
    EXPECT_EQ(interfaces.GetNumberOfFacets() + outer, facets.GetNumberOfFacets());
    EXPECT_EQ(outer == 0, border);
  }
}

// 1D: the points between materials and at the ends; 4D: two materials split along the first
// axis, the interface's measure in facets (Kuhn: 3! = 6 tetrahedra per cube face).
TEST(InterfaceFacets, OneAndFourDimensions)
{
  stm::SequentialExecutor executor;
  {
    const std::vector<double> points{ 0, 1, 2, 3, 4 };
    const std::vector<std::int64_t> cells{ 0, 1, 1, 2, 2, 3, 3, 4 };
    const std::vector<std::int64_t> materials{ 1, 1, 2, 3 };
    stm::InterfaceFacets<1> facets;
    ASSERT_TRUE(stm::ExtractInterfaceFacets<1>(points.data(), 5, cells.data(), 4, materials.data(),
      stm::InterfaceFacetOptions(), executor, facets)
                  .IsOk());
    EXPECT_EQ(facets.Connectivity, (std::vector<std::int64_t>{ 0, 2, 3, 4 }));
    EXPECT_EQ(facets.Labels, (std::vector<std::int64_t>{ 1, -1, 1, 2, 2, 3, 3, -1 }));
  }
  {
    LabelImage<4> image(UniformExtents<4>(2));
    ForEachIndex<4>(image.GetDimensions(),
      [&](const stm::LatticeIndex<4>& voxel) { image.Set(voxel, voxel[0] == 0 ? 1 : 2); });
    stm::Spacetree<4> tree;
    ASSERT_TRUE(BuildTree<4>(image, 1, 1, false, executor, tree).IsOk());
    stm::SpacetreeTessellationOptions tessellation;
    tessellation.Template = stm::CellTemplate::Kuhn;
    SimplicialMesh<4> mesh;
    ASSERT_TRUE(TessellateTree<4>(tree, tessellation, executor, mesh).IsOk());
    const std::vector<double> points = mesh.Coordinates();
    const std::vector<std::int64_t> materials = mesh.MaterialsAsInt64();
    stm::InterfaceFacetOptions options;
    options.IncludeOuterBoundary = false;
    stm::InterfaceFacets<4> facets;
    ASSERT_TRUE(stm::ExtractInterfaceFacets<4>(points.data(), mesh.GetNumberOfPoints(),
      mesh.Connectivity.data(), mesh.GetNumberOfSimplices(), materials.data(), options, executor,
      facets)
                  .IsOk());
    // The interface x0 = 1 has 2^3 unit cube faces.
    EXPECT_EQ(facets.GetNumberOfFacets(), 8 * 6);
    for (std::int64_t f = 0; f < facets.GetNumberOfFacets(); ++f)
    {
      EXPECT_EQ(facets.Labels[2 * f], 1);
      EXPECT_EQ(facets.Labels[2 * f + 1], 2);
      for (int k = 0; k < 4; ++k)
      {
        EXPECT_EQ(points[facets.Connectivity[f * 4 + k] * 4], 1.0);
      }
    }
  }
}

TEST(InterfaceFacets, RejectsBadIds)
{
  stm::SequentialExecutor executor;
  const std::vector<double> points{ 0, 0, 1, 0, 0, 1 };
  const std::vector<std::int64_t> cells{ 0, 1, 3 };
  stm::InterfaceFacets<2> facets;
  const stm::Status status = stm::ExtractInterfaceFacets<2>(points.data(), 3, cells.data(), 1,
    static_cast<const std::int64_t*>(nullptr), stm::InterfaceFacetOptions(), executor, facets);
  EXPECT_FALSE(status.IsOk());
  EXPECT_NE(status.GetMessage().find("outside the mesh"), std::string::npos);
}
} // namespace
