// SPDX-License-Identifier: BSD-3-Clause
/**
 * @class   stmSpacetreeTessellate
 * @brief   conforming simplicial or hybrid mesh, or the leaf cells, of a spacetree
 *
 * stmSpacetreeTessellate turns the spacetree of stmImageToSpacetree (balanced by
 * stmSpacetreeBalance or not) into a mesh, by the paper's direct tessellation (sections 2.3 and
 * 2.4). Three outputs (OutputType):
 * - SIMPLICIAL: a conforming mesh of tetrahedra (triangles in 2D). A leaf, or a face of one, with
 *   no extra spacetree vertex on its boundary takes a fixed template without new points; any
 *   other gets its centre joined to the triangulations of its facets (recursive midpoint rule).
 *   TemplateRule chooses the midpoint rule everywhere, templates for regular faces (the
 *   default), or in addition extended templates: an irregular face that can be a cone from one
 *   of its corners becomes that cone, without a new point.
 * - HYBRID: the paper's hybrid rule. A face is tessellated (centre joined to its facets) if and
 *   only if one of its facets is; every other leaf stays a hexahedron (quad), glued to the
 *   tetrahedra by pyramids. Conforming: a quadrilateral face is shared by two cells or lies on
 *   the boundary.
 * - LEAVES: the leaf cells themselves as hexahedra (quads), not conforming where leaves of
 *   different levels meet; the point array "HangingNode" is 1 at the points that lie on an edge
 *   or face of a neighbouring leaf without being its corner.
 * Because the triangulation of every face depends only on that face, the mesh is consistent
 * across faces for any level difference, and the work is linear in the number of leaves. The
 * mesh covers exactly the voxels of the body of interest (plus BoundaryLayers layers of
 * background leaves), so each material's volume equals its voxel volume.
 *
 * Output: a vtkUnstructuredGrid of VTK_TETRA, VTK_PYRAMID and VTK_HEXAHEDRON (VTK_TRIANGLE and
 * VTK_QUAD in 2D), positively oriented, with the cell array "Material" (the label of the leaf)
 * and, unless SeparatingFunction is NO_FUNCTION, the point array "SeparatingFunction" that
 * stmMarchingSimplices cuts at 0 by default (negative inside the body).
 * Points are numbered in lattice order, so the output does not depend on the number of
 * threads.
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
   * The template for leaves (and faces) without extra vertices on their boundary, in
   * SIMPLICIAL output. Default CHECKERBOARD (5 tetrahedra per cube, as in the paper).
   */
  vtkSetClampMacro(CellTemplate, int, CHECKERBOARD, KUHN);
  vtkGetMacro(CellTemplate, int);
  ///@}

  enum OutputTypes
  {
    /// Conforming tetrahedra (triangles in 2D).
    SIMPLICIAL = 0,
    /// Conforming hexahedra, pyramids and tetrahedra (quads and triangles in 2D).
    HYBRID = 1,
    /// The leaf cells as hexahedra (quads), with hanging nodes.
    LEAVES = 2
  };

  enum TemplateRules
  {
    /// The recursive midpoint rule for every face, regular or not (paper Fig. 3a).
    MIDPOINT_EVERYWHERE = 0,
    /// Templates for regular faces, the midpoint rule for the others (paper section 2.4).
    REGULAR_FACES = 1,
    /// In addition, irregular faces that can be cones from a corner become that cone without a
    /// new point (the paper's extended templates).
    EXTENDED = 2
  };

  ///@{
  /**
   * The cells to output: SIMPLICIAL, HYBRID or LEAVES. Default SIMPLICIAL.
   */
  vtkSetClampMacro(OutputType, int, SIMPLICIAL, LEAVES);
  vtkGetMacro(OutputType, int);
  ///@}

  ///@{
  /**
   * How SIMPLICIAL output triangulates unsplit faces: MIDPOINT_EVERYWHERE, REGULAR_FACES or
   * EXTENDED. Default REGULAR_FACES. HYBRID and LEAVES output ignore it.
   */
  vtkSetClampMacro(TemplateRule, int, MIDPOINT_EVERYWHERE, EXTENDED);
  vtkGetMacro(TemplateRule, int);
  ///@}

  ///@{
  /**
   * Number of layers of background leaves around the body of interest to output as well
   * (Material = the background label), 0 to 100: layer 1 holds the background leaves touching
   * the body, layer 2 those touching layer 1, and so on, so that a later cut can move the
   * boundary outward. Default 0. IncludeBackground outputs every background leaf instead.
   */
  vtkSetClampMacro(BoundaryLayers, int, 0, 100);
  vtkGetMacro(BoundaryLayers, int);
  ///@}

  enum SeparatingFunctions
  {
    /// No point array; the boundary stays the voxel staircase.
    NO_FUNCTION = 0,
    /// The d-linear interpolation of the body indicator (-1 inside, +1 outside) on the dual grid
    /// of the voxel centres (paper section 3.1).
    LABELS = 1,
    /// The same indicator smoothed by a Gaussian of SmoothingSigma (mm) first.
    SMOOTHED_LABELS = 2
  };

  ///@{
  /**
   * The point array "SeparatingFunction" to compute for stmMarchingSimplices: NO_FUNCTION,
   * LABELS (the default) or SMOOTHED_LABELS. Its zero set lies within half a voxel of the body's
   * voxels (LABELS) or within a few SmoothingSigma (SMOOTHED_LABELS), so unless
   * IncludeBackground is on, the output gets at least the background layers that keep that zero
   * set inside the mesh (1 for LABELS; 1 + 3 sigma / the smallest voxel edge for
   * SMOOTHED_LABELS, at most 100) even when BoundaryLayers asks for fewer.
   */
  vtkSetClampMacro(SeparatingFunction, int, NO_FUNCTION, SMOOTHED_LABELS);
  vtkGetMacro(SeparatingFunction, int);
  ///@}

  ///@{
  /**
   * The standard deviation of the Gaussian of SMOOTHED_LABELS, in physical units (mm),
   * 0.01 to 1000. Default 1.
   */
  vtkSetClampMacro(SmoothingSigma, double, 0.01, 1000.0);
  vtkGetMacro(SmoothingSigma, double);
  ///@}

  /**
   * The background layers the last update output (BoundaryLayers, or more for the separating
   * function).
   */
  vtkGetMacro(NumberOfBoundaryLayers, int);

  /**
   * Points the last update added to the leaf corners (face and cell centres), for reports.
   */
  vtkGetMacro(NumberOfInsertedPoints, vtkIdType);

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

  int OutputType = SIMPLICIAL;
  int TemplateRule = REGULAR_FACES;
  int CellTemplate = CHECKERBOARD;
  bool IncludeBackground = false;
  int BoundaryLayers = 0;
  int SeparatingFunction = LABELS;
  double SmoothingSigma = 1.0;
  vtkIdType NumberOfInsertedPoints = 0;
  int NumberOfBoundaryLayers = 0;

private:
  stmSpacetreeTessellate(const stmSpacetreeTessellate&) = delete;
  void operator=(const stmSpacetreeTessellate&) = delete;
};

#endif
