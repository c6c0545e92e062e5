// SPDX-License-Identifier: BSD-3-Clause
/**
 * @brief   the spacetree as a VTK dataset, and back (private to the module)
 *
 * A spacetree travels between the filters (and to files) as a vtkUnstructuredGrid: one
 * hexahedron (quad in 2D) per leaf on shared corner points, cell arrays "Level", "Material"
 * and "LatticeIndex", and field data holding the root grid, the image geometry and the
 * material table. Reading validates everything, including that the leaves partition the root
 * grid, so a corrupt or hand-edited dataset gets an error instead of a broken mesh.
 */

#ifndef stmSpacetreeData_h
#define stmSpacetreeData_h

#include "Spacetree/Spacetree.h"

#include <cstdint>
#include <string>
#include <vector>

class vtkAlgorithm;
class vtkFieldData;
class vtkInformationVector;
class vtkUnstructuredGrid;

/// Where the spacetree lattice sits in physical space.
struct stmSpacetreeGeometry
{
  /// 2 or 3.
  int Dimension = 3;
  /// The image axis (0, 1, 2) of each spacetree axis.
  int ImageAxes[3] = { 0, 1, 2 };
  /// Physical position of lattice point 0 (the outer corner of the first voxel).
  double Origin[3] = { 0, 0, 0 };
  /// Physical vector of one lattice unit along each image axis (a voxel edge, or a fraction of
  /// it where cells are refined below the voxel).
  double AxisVectors[3][3] = { { 1, 0, 0 }, { 0, 1, 0 }, { 0, 0, 1 } };
  /// A piece of a larger image (stmImageToSpacetree::SplitIntoPieces): the root cells
  /// [OwnedRootLower, OwnedRootUpper) of this tree (per spacetree axis) are the piece's own;
  /// the others are its ghost layer, whose leaves and cells carry vtkGhostType DUPLICATECELL.
  bool IsPiece = false;
  long long OwnedRootLower[3] = { 0, 0, 0 };
  long long OwnedRootUpper[3] = { 0, 0, 0 };

  /// Lattice units from Origin to the tree's lattice point 0 per spacetree axis: 0 for a whole
  /// image; for a piece, where its first voxel lies in the whole image, so that its points are
  /// computed as the whole image's are, bit for bit.
  double LatticeOffset[3] = { 0, 0, 0 };

  /// x = Origin + sum_i (LatticeOffset[i] + lattice[i]) * AxisVectors[ImageAxes[i]], for
  /// Dimension coordinates.
  void ToPhysical(const double* lattice, double x[3]) const
  {
    for (int c = 0; c < 3; ++c)
    {
      x[c] = this->Origin[c];
    }
    for (int i = 0; i < this->Dimension; ++i)
    {
      const double* axis = this->AxisVectors[this->ImageAxes[i]];
      const double position = this->LatticeOffset[i] + lattice[i];
      for (int c = 0; c < 3; ++c)
      {
        x[c] += position * axis[c];
      }
    }
  }
};

namespace stmSpacetreeData
{
/// The start of RequestData of a filter that consumes a spacetree: the grid on the input port
/// and its geometry. False when the filter must stop: the output is then cleared, an error is
/// reported unless an upstream filter was aborted, and requestResult is what RequestData returns.
bool BeginRequest(vtkAlgorithm* filter, vtkInformationVector* inputPort,
  vtkUnstructuredGrid* output, vtkUnstructuredGrid*& input, stmSpacetreeGeometry& geometry,
  int& requestResult);

/// The end of RequestData of such a filter: on failure the output is cleared and the error
/// reported, unless the filter itself was aborted. Returns what RequestData returns.
int EndRequest(
  vtkAlgorithm* filter, bool succeeded, const std::string& error, vtkUnstructuredGrid* output);

/// Removes the spacetree's field arrays (a mesh is not a spacetree), except the marker of a
/// piece (MarkPiece), which the mesh keeps.
void RemoveSpacetreeFieldData(vtkFieldData* fieldData);

/// Rebuilds the core spacetree; false with a message if anything is missing or inconsistent.
template <int Dim>
bool ReadSpacetree(vtkUnstructuredGrid* input, stm::Spacetree<Dim>& tree, std::string& error);

/// For a piece's tree (stmSpacetreeGeometry::IsPiece): writes per leaf into `marks` `mark`
/// where its root cell lies outside the piece's own box grown by `grownBy` root cells, else 0.
/// With grownBy 0 and vtkDataSetAttributes::DUPLICATECELL: the ghost leaves.
template <int Dim>
void MarkLeavesOutsideOwnedBox(const stm::Spacetree<Dim>& tree,
  const stmSpacetreeGeometry& geometry, int grownBy, std::uint8_t mark, std::uint8_t* marks);

/// Writes the spacetree and its geometry into an (empty) unstructured grid; a piece's tree also
/// gets its owned root cells, the piece marker and vtkGhostType on the ghost leaves.
template <int Dim>
void WriteSpacetree(const stm::Spacetree<Dim>& tree, const stmSpacetreeGeometry& geometry,
  vtkUnstructuredGrid* output);
}

#endif
