// SPDX-License-Identifier: BSD-3-Clause
/**
 * @class   stmMultiMaterialCut
 * @brief   cuts a labelled tetrahedral (triangle) mesh at the smooth interfaces between any
 *          number of materials, conforming, one material per element
 *
 * stmMultiMaterialCut is marching simplices for N materials. The input is a mesh of only
 * tetrahedra (or only triangles in a plane) with the cell array "Material", such as the
 * simplicial output of stmSpacetreeTessellate on a label image with several labels. Every point
 * gets, for each material, the share of the solid angle (angle in 2D) around it that the
 * material's cells cover; on a tessellation of voxels this is the d-linear interpolation of each
 * material's voxel indicator, the labels separating function of every material at once. On the
 * mesh boundary the angle outside belongs to BackgroundMaterial, as the voxels beyond an image
 * are background. A material's region is where its fraction is the largest.
 *
 * The materials are peeled in turn, the labels ascending and BackgroundMaterial last: each step
 * snaps the points next to its interface onto it (VertexSnapping), cuts the cells not yet
 * assigned at the zero of (largest fraction of the materials after it) - (its own fraction)
 * with the binary marching simplices, and assigns the negative pieces. A
 * cut splits every cell around its edge, already assigned or not (an assigned piece keeps its
 * material), so interfaces, triple lines and quadruple points are conforming and watertight and
 * every piece has positive volume (see Filters/Core/Cut/MultiMaterialCut.h). With two materials
 * and VertexSnapping off the result is exactly stmMarchingSimplices on the labels function.
 *
 * Output: a vtkUnstructuredGrid of the pieces, in the order of the input cells they lie in
 * followed by the pieces added by later steps; the input points first, then the added points,
 * each on an edge of the mesh at the time it was cut (its point data interpolated along that
 * edge; a snapped point keeps its point data). The cell array "Material" is the piece's material,
 * "OriginalMaterial" the input cell's Material; other cell arrays are copied from the input cell.
 * The result does not depend on the number of threads.
 *
 * A piece of a larger image (stmImageToSpacetree::SplitIntoPieces): the output keeps of the
 * piece's ghost cells the rings its request asks for (ghost levels), and at least the cells that
 * share a point with the piece's own cells, which is all that stmBoundarySmooth needs. When
 * every rank of an MPI run asks for its own piece and has ghost cells, the snaps of the steps
 * whose materials lie near a piece's border exchange the points' states with the other ranks
 * after every round, so the owned cells are the whole mesh's cut; then every rank must execute
 * the filter, as with VTK's other parallel filters.
 *
 * @sa stmMarchingSimplices stmSpacetreeTessellate stmBoundarySmooth stmInterfaceSurface
 */

#ifndef stmMultiMaterialCut_h
#define stmMultiMaterialCut_h

#include "SpacetreeMeshFiltersModule.h" // for export macro
#include "vtkUnstructuredGridAlgorithm.h"

class SPACETREEMESHFILTERS_EXPORT stmMultiMaterialCut : public vtkUnstructuredGridAlgorithm
{
public:
  static stmMultiMaterialCut* New();
  vtkTypeMacro(stmMultiMaterialCut, vtkUnstructuredGridAlgorithm);
  void PrintSelf(ostream& os, vtkIndent indent) override;

  ///@{
  /**
   * The Material of the background: peeled last, and the owner of the angle outside the mesh.
   * It need not occur in the mesh. Default 0.
   */
  vtkSetMacro(BackgroundMaterial, int);
  vtkGetMacro(BackgroundMaterial, int);
  ///@}

  ///@{
  /**
   * Before each material is cut, move the points next to its interface onto it instead of
   * cutting the edges close to them (stmVertexSnap's quality-driven rule: a point snaps along
   * one of its cut edges, or its value is nudged, where that gives better cut elements).
   * Points move only where every cell around them is one the step cuts; a moved point takes the
   * fractions of its new place. Default on.
   */
  vtkSetMacro(VertexSnapping, bool);
  vtkGetMacro(VertexSnapping, bool);
  vtkBooleanMacro(VertexSnapping, bool);
  ///@}

  ///@{
  /**
   * Differences of fractions within this of 0 are ties: such points lie on the interface and
   * edges to them are not cut. In [0, 0.5). Default 1e-9 (fractions of a voxel tessellation are
   * multiples of 1/2^d up to rounding, so its ties are exact).
   */
  vtkSetClampMacro(ZeroTolerance, double, 0.0, 0.49);
  vtkGetMacro(ZeroTolerance, double);
  ///@}

  /**
   * The materials of the last update; its splits of a cell, summed over the steps; of those,
   * the splits of cells whose material was already assigned (along triple lines); the points
   * it added; and its snaps, summed over the steps.
   */
  vtkGetMacro(NumberOfMaterials, int);
  vtkGetMacro(NumberOfSplitCells, vtkIdType);
  vtkGetMacro(NumberOfSplitAssignedCells, vtkIdType);
  vtkGetMacro(NumberOfCutPoints, vtkIdType);
  vtkGetMacro(NumberOfSnappedPoints, vtkIdType);

protected:
  stmMultiMaterialCut() = default;
  ~stmMultiMaterialCut() override = default;

  int RequestData(vtkInformation* request, vtkInformationVector** inputVector,
    vtkInformationVector* outputVector) override;

private:
  stmMultiMaterialCut(const stmMultiMaterialCut&) = delete;
  void operator=(const stmMultiMaterialCut&) = delete;

  int BackgroundMaterial = 0;
  double ZeroTolerance = 1e-9;
  bool VertexSnapping = true;
  int NumberOfMaterials = 0;
  vtkIdType NumberOfSplitCells = 0;
  vtkIdType NumberOfSplitAssignedCells = 0;
  vtkIdType NumberOfCutPoints = 0;
  vtkIdType NumberOfSnappedPoints = 0;
};

#endif
