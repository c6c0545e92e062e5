// SPDX-License-Identifier: BSD-3-Clause
/**
 * @class   stmMarchingSimplices
 * @brief   cuts a simplicial mesh at an iso-surface of a point scalar, conforming, with the
 *          zero-vertex cases
 *
 * stmMarchingSimplices is the paper's volumetric marching simplices (section 3.2). The input is
 * any vtkUnstructuredGrid of tetrahedra (3D) or triangles (2D), from stmSpacetreeTessellate or
 * another mesher, and a point scalar f (input array 0; by default "SeparatingFunction", which
 * stmSpacetreeTessellate computes; when the selection names no array, that array or else the
 * active point scalars). Each point is classed negative (f < IsoValue - ZeroTolerance,
 * inside), zero or positive (outside). Only edges from a negative to a positive point are cut,
 * each at the zero of the linear interpolant, by one new point shared by every cell around the
 * edge. A cell with both signs is split into its two convex pieces (in 3D: tetrahedron + prism,
 * two prisms, tetrahedron + pyramid, two tetrahedra), and these into simplices by the
 * smallest-global-vertex rule (each face is cut by a rule that depends only on the face and the
 * point numbers), so the output is conforming without extra points. Cells whose points are all
 * zero keep their side from the input cell array "Material" (inside unless it equals
 * OutsideMaterial) or, without it, from the sign of the sum of f - IsoValue.
 *
 * Output (OutputMode):
 * - VOLUME: a vtkUnstructuredGrid of the pieces on both sides (or one, KeepSide), in input cell
 *   order. The cell array "Material" becomes InsideMaterial or OutsideMaterial; the input's
 *   "Material" is kept as "OriginalMaterial", and every other cell array is copied from the
 *   parent cell. Point arrays are interpolated along the cut edges. Cut points are numbered
 *   after the input points in sorted edge order, so the output does not depend on the cell
 *   order or the number of threads.
 * - SURFACE: a vtkPolyData of the interface between inside and outside pieces (cut facets and
 *   zero facets of the input): triangles oriented outward with the cell array "Normals" (line
 *   segments in 2D), and the point arrays interpolated.
 *
 * A piece of a larger image (stmImageToSpacetree::SplitIntoPieces): the VOLUME output keeps of
 * the piece's ghost cells the rings its request asks for (ghost levels), and at least the cells
 * that share a point with the piece's own cells, which is all that stmBoundarySmooth needs; the
 * rest of the ghost layer served the snapping and the cut.
 *
 * @sa stmSpacetreeTessellate stmSeparatingFunction
 */

#ifndef stmMarchingSimplices_h
#define stmMarchingSimplices_h

#include "SpacetreeMeshFiltersModule.h" // for export macro
#include "vtkDataObjectAlgorithm.h"

class SPACETREEMESHFILTERS_EXPORT stmMarchingSimplices : public vtkDataObjectAlgorithm
{
public:
  static stmMarchingSimplices* New();
  vtkTypeMacro(stmMarchingSimplices, vtkDataObjectAlgorithm);
  void PrintSelf(ostream& os, vtkIndent indent) override;

  enum OutputModes
  {
    /// The cut mesh: simplices on both sides of the surface (vtkUnstructuredGrid).
    VOLUME = 0,
    /// The iso-surface: triangles (segments in 2D) oriented outward (vtkPolyData).
    SURFACE = 1
  };

  enum KeptSides
  {
    BOTH = 0,
    /// Only the pieces with f < IsoValue.
    INSIDE = 1,
    /// Only the pieces with f > IsoValue.
    OUTSIDE = 2
  };

  ///@{
  /**
   * The separating surface is f = IsoValue; f below it is inside. Default 0.
   */
  vtkSetMacro(IsoValue, double);
  vtkGetMacro(IsoValue, double);
  ///@}

  ///@{
  /**
   * A point with |f - IsoValue| <= ZeroTolerance lies on the surface (a zero vertex): edges to
   * it are not cut. In the units of f, >= 0. Default 1e-9 (the default separating function
   * takes exact multiples of 1/4 in 3D, so its zeros are exact).
   */
  vtkSetClampMacro(ZeroTolerance, double, 0.0, VTK_DOUBLE_MAX);
  vtkGetMacro(ZeroTolerance, double);
  ///@}

  ///@{
  /**
   * VOLUME (the default) or SURFACE.
   */
  vtkSetClampMacro(OutputMode, int, VOLUME, SURFACE);
  vtkGetMacro(OutputMode, int);
  ///@}

  ///@{
  /**
   * Which pieces VOLUME output keeps: BOTH (the default), INSIDE or OUTSIDE. Points no kept
   * cell uses are removed.
   */
  vtkSetClampMacro(KeepSide, int, BOTH, OUTSIDE);
  vtkGetMacro(KeepSide, int);
  ///@}

  ///@{
  /**
   * The "Material" of inside pieces. Default 1.
   */
  vtkSetMacro(InsideMaterial, int);
  vtkGetMacro(InsideMaterial, int);
  ///@}

  ///@{
  /**
   * The "Material" of outside pieces; an all-zero input cell with this Material stays outside.
   * Default 0 (the background label).
   */
  vtkSetMacro(OutsideMaterial, int);
  vtkGetMacro(OutsideMaterial, int);
  ///@}

  /**
   * Input cells the last update split, and the points it added.
   */
  vtkGetMacro(NumberOfSplitCells, vtkIdType);
  vtkGetMacro(NumberOfCutPoints, vtkIdType);

protected:
  stmMarchingSimplices();
  ~stmMarchingSimplices() override;

  int FillInputPortInformation(int port, vtkInformation* info) override;
  int FillOutputPortInformation(int port, vtkInformation* info) override;
  int RequestDataObject(vtkInformation* request, vtkInformationVector** inputVector,
    vtkInformationVector* outputVector) override;
  int RequestData(vtkInformation* request, vtkInformationVector** inputVector,
    vtkInformationVector* outputVector) override;

private:
  stmMarchingSimplices(const stmMarchingSimplices&) = delete;
  void operator=(const stmMarchingSimplices&) = delete;

  double IsoValue = 0.0;
  double ZeroTolerance = 1e-9;
  int OutputMode = VOLUME;
  int KeepSide = BOTH;
  int InsideMaterial = 1;
  int OutsideMaterial = 0;
  vtkIdType NumberOfSplitCells = 0;
  vtkIdType NumberOfCutPoints = 0;
};

#endif
