// SPDX-License-Identifier: BSD-3-Clause
#ifndef stmCoreInterfaceFacets_h
#define stmCoreInterfaceFacets_h

// The interfaces of a simplicial mesh with a material per cell, as facets labelled with the
// materials on their two sides (issue 7: every interface between any number of materials, for
// visualisation and boundary conditions; VTK's SurfaceNets calls the pair BoundaryLabels).
//
// Decisions:
// - A facet is an interface facet when its two cells have different materials, or, with
//   IncludeOuterBoundary, when it is on the outer boundary (in one cell only) and its cell is
//   not BackgroundMaterial (the box of background the tessellation adds stays out, as in
//   boundary smoothing); the outside is then labelled OuterLabel.
// - Each facet appears once, oriented as part of the boundary of the cell it is written from,
//   so that its normal (right-hand rule in 3D; in 2D the segment's direction turned clockwise)
//   points out of that cell: the cell of the smaller material for an interface, the only cell
//   on the outer boundary. Labels[0] is that cell's material, Labels[1] the other side's.
//   Cells of negative orientation are handled (their facets are reversed).
// - Facets are ordered by the cell they are written from, then by the corner opposite them, so
//   the output does not depend on the number of threads.

#include "Common/Determinant.h"
#include "Common/Execution.h"
#include "Common/PointCells.h"
#include "Common/Status.h"

#include <algorithm>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

namespace stm
{

struct InterfaceFacetOptions
{
  /// Also the outer-boundary facets of cells that are not BackgroundMaterial.
  bool IncludeOuterBoundary = true;
  std::int64_t BackgroundMaterial = 0;
  /// The label of the outside of the outer boundary.
  std::int64_t OuterLabel = -1;
};

template <int Dim>
struct InterfaceFacets
{
  /// Dim point ids per facet, oriented out of the cell of Labels[0].
  std::vector<std::int64_t> Connectivity;
  /// Two per facet: the material the facet's normal points out of, then the other side's.
  std::vector<std::int64_t> Labels;
  /// Per facet, the cell it was written from.
  std::vector<std::int64_t> Cells;

  std::int64_t GetNumberOfFacets() const { return static_cast<std::int64_t>(this->Cells.size()); }
};

/// The interface facets of a mesh of simplices (Dim + 1 point ids per cell, `points` Dim
/// coordinates per point) with per-cell `materials` (nullptr: one material for every cell, so
/// only the outer boundary).
template <int Dim, class IdType, class MaterialType, class Executor>
Status ExtractInterfaceFacets(const double* points, std::int64_t numberOfPoints,
  const IdType* connectivity, std::int64_t numberOfCells, const MaterialType* materials,
  const InterfaceFacetOptions& options, Executor& executor, InterfaceFacets<Dim>& facets)
{
  static_assert(Dim >= 1 && Dim <= 4, "interface extraction supports dimensions 1 to 4");
  facets = InterfaceFacets<Dim>();
  if (numberOfPoints < 0 || numberOfCells < 0 || (numberOfPoints > 0 && !points))
  {
    return Status::Invalid("no points or negative counts");
  }
  for (std::int64_t i = 0; i < numberOfCells * (Dim + 1); ++i)
  {
    if (connectivity[i] < 0 || static_cast<std::int64_t>(connectivity[i]) >= numberOfPoints)
    {
      return Status::Invalid(
        "cell " + std::to_string(i / (Dim + 1)) + " refers to a point id outside the mesh");
    }
  }
  PointCells<Dim> incidence;
  incidence.Build(connectivity, numberOfCells, numberOfPoints, executor);
  if (executor.ShouldAbort())
  {
    return Status::Aborted();
  }
  executor.ReportProgress(0.3);
  auto materialOf = [&](std::int64_t cell) {
    return materials ? static_cast<std::int64_t>(materials[cell]) : options.BackgroundMaterial + 1;
  };

  // Fixed blocks of cells, each with its own list, joined in block order.
  constexpr std::int64_t BlockSize = 1 << 14;
  const std::int64_t blocks = (numberOfCells + BlockSize - 1) / BlockSize;
  std::vector<InterfaceFacets<Dim>> perBlock(static_cast<std::size_t>(blocks));
  struct Kernel
  {
    using Scratch = NoScratch;
    const double* Points;
    const IdType* Connectivity;
    std::int64_t NumberOfCells;
    const PointCells<Dim>* Incidence;
    const decltype(materialOf)* MaterialOf;
    const InterfaceFacetOptions* Options;
    std::vector<InterfaceFacets<Dim>>* PerBlock;
    Executor* Runner;
    void operator()(Scratch&, std::int64_t begin, std::int64_t end) const
    {
      for (std::int64_t block = begin; block < end && !this->Runner->ShouldAbort(); ++block)
      {
        if (block % 16 == 0)
        {
          this->Runner->ReportProgress(
            0.3 + 0.5 * static_cast<double>(block) / static_cast<double>(this->PerBlock->size()));
        }
        InterfaceFacets<Dim>& out = (*this->PerBlock)[block];
        const std::int64_t last = std::min(this->NumberOfCells, (block + 1) * BlockSize);
        for (std::int64_t c = block * BlockSize; c < last; ++c)
        {
          const IdType* ids = this->Connectivity + c * (Dim + 1);
          const std::int64_t own = (*this->MaterialOf)(c);
          bool orientationKnown = false, negative = false;
          for (int i = 0; i <= Dim; ++i)
          {
            const std::int64_t neighbour = this->Incidence->FacetNeighbour(ids, c, i);
            std::int64_t other = 0;
            if (neighbour < 0)
            {
              if (!this->Options->IncludeOuterBoundary || own == this->Options->BackgroundMaterial)
              {
                continue;
              }
              other = this->Options->OuterLabel;
            }
            else
            {
              other = (*this->MaterialOf)(neighbour);
              // Written once, from the cell of the smaller material.
              if (other <= own)
              {
                continue;
              }
            }
            if (!orientationKnown)
            {
              double edges[Dim][Dim];
              for (int col = 0; col < Dim; ++col)
              {
                for (int r = 0; r < Dim; ++r)
                {
                  edges[r][col] = this->Points[static_cast<std::int64_t>(ids[col + 1]) * Dim + r] -
                    this->Points[static_cast<std::int64_t>(ids[0]) * Dim + r];
                }
              }
              negative = Determinant<Dim>(edges) < 0.0;
              orientationKnown = true;
            }
            // The boundary of [v0 .. vDim] is the sum of (-1)^i [v0 .. (no vi) .. vDim].
            std::int64_t facet[Dim];
            for (int j = 0, f = 0; j <= Dim; ++j)
            {
              if (j != i)
              {
                facet[f++] = static_cast<std::int64_t>(ids[j]);
              }
            }
            if (Dim >= 2 && ((i % 2 == 1) != negative))
            {
              std::swap(facet[0], facet[1]);
            }
            out.Connectivity.insert(out.Connectivity.end(), facet, facet + Dim);
            out.Labels.push_back(own);
            out.Labels.push_back(other);
            out.Cells.push_back(c);
          }
        }
      }
    }
  };
  Kernel kernel{ points, connectivity, numberOfCells, &incidence, &materialOf, &options, &perBlock,
    &executor };
  executor.For(0, blocks, 1, kernel);
  if (executor.ShouldAbort())
  {
    return Status::Aborted();
  }
  executor.ReportProgress(0.8);
  std::size_t total = 0;
  for (const InterfaceFacets<Dim>& block : perBlock)
  {
    total += block.Cells.size();
  }
  facets.Connectivity.reserve(total * Dim);
  facets.Labels.reserve(total * 2);
  facets.Cells.reserve(total);
  for (InterfaceFacets<Dim>& block : perBlock)
  {
    facets.Connectivity.insert(
      facets.Connectivity.end(), block.Connectivity.begin(), block.Connectivity.end());
    facets.Labels.insert(facets.Labels.end(), block.Labels.begin(), block.Labels.end());
    facets.Cells.insert(facets.Cells.end(), block.Cells.begin(), block.Cells.end());
    block = InterfaceFacets<Dim>();
  }
  executor.ReportProgress(1.0);
  return Status::Ok();
}

} // namespace stm

#endif
