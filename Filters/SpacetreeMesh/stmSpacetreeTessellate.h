// SPDX-License-Identifier: BSD-3-Clause
/**
 * @class   stmSpacetreeTessellate
 * @brief   conforming simplicial mesh of the spacetree leaves
 *
 * stmSpacetreeTessellate turns the spacetree of stmImageToSpacetree (balanced by
 * stmSpacetreeBalance or not) into a conforming mesh of tetrahedra (triangles in 2D), by the
 * paper's direct tessellation (sections 2.3 and 2.4): a leaf, or a face of one, with no extra
 * spacetree vertex on its boundary takes a fixed template without new points; any other gets
 * its centre joined to the triangulations of its facets (recursive midpoint rule). Because the
 * triangulation of every face depends only on that face, the mesh is consistent across faces for
 * any level difference, and the work is linear in the number of leaves. The mesh covers exactly
 * the voxels of the body of interest, so each material's volume equals its voxel volume.
 *
 * Output: a vtkUnstructuredGrid of VTK_TETRA (VTK_TRIANGLE in 2D), positively oriented, with
 * the cell array "Material" (the label of the leaf). Points are numbered in lattice order, so
 * the output does not depend on the number of threads.
 *
 * @sa stmImageToSpacetree stmSpacetreeBalance
 */

#ifndef stmSpacetreeTessellate_h
#define stmSpacetreeTessellate_h

#include "SpacetreeMeshFiltersModule.h" // for export macro
#include "vtkUnstructuredGridAlgorithm.h"

class SPACETREEMESHFILTERS_EXPORT stmSpacetreeTessellate : public vtkUnstructuredGridAlgorithm
{
public:
  static stmSpacetreeTessellate* New();
  vtkTypeMacro(stmSpacetreeTessellate, vtkUnstructuredGridAlgorithm);
  void PrintSelf(ostream& os, vtkIndent indent) override;

  enum CellTemplates
  {
    /// Squares into 2 triangles and cubes into 5 tetrahedra, alternating like a checkerboard.
    CHECKERBOARD = 0,
    /// Cubes into the 6 Kuhn (Freudenthal) tetrahedra around the main diagonal.
    KUHN = 1
  };

  ///@{
  /**
   * The template for leaves (and faces) without extra vertices on their boundary.
   * Default CHECKERBOARD (5 tetrahedra per cube, as in the paper).
   */
  vtkSetClampMacro(CellTemplate, int, CHECKERBOARD, KUHN);
  vtkGetMacro(CellTemplate, int);
  ///@}

  ///@{
  /**
   * Also tessellate the background leaves (Material = the background label), giving a mesh of
   * the whole root grid. Default off: only the body of interest.
   */
  vtkSetMacro(IncludeBackground, bool);
  vtkGetMacro(IncludeBackground, bool);
  vtkBooleanMacro(IncludeBackground, bool);
  ///@}

protected:
  stmSpacetreeTessellate();
  ~stmSpacetreeTessellate() override;

  int RequestData(vtkInformation* request, vtkInformationVector** inputVector,
    vtkInformationVector* outputVector) override;

  int CellTemplate = CHECKERBOARD;
  bool IncludeBackground = false;

private:
  stmSpacetreeTessellate(const stmSpacetreeTessellate&) = delete;
  void operator=(const stmSpacetreeTessellate&) = delete;
};

#endif
