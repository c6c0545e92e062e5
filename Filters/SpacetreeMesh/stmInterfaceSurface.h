// SPDX-License-Identifier: BSD-3-Clause
/**
 * @class   stmInterfaceSurface
 * @brief   extracts the interfaces between the materials of a tetrahedral (triangle) mesh as
 *          polydata labelled with the material on each side
 *
 * stmInterfaceSurface writes every facet of the input whose two cells have different "Material"
 * values, and, with IncludeOuterBoundary, every outer-boundary facet of a cell that is not
 * BackgroundMaterial (so the box of background the tessellation adds around the body stays
 * out; the outside is labelled OuterLabel). Each facet appears once, as a triangle (3D) or a
 * line (2D), with the two-component cell array "BoundaryLabels" (as VTK's vtkSurfaceNets3D
 * names it): component 0 the material the facet's normal points out of, component 1 the
 * material on the other side. For an interface component 0 is the smaller material; on the
 * outer boundary it is the cell's. So the facets of one material, turned where it is
 * component 1, form its closed boundary with outward normals: a surface per region or per pair
 * for visualisation, and for boundary conditions. Points are the input's points used by a facet
 * (with their point data); the cell array "CellId" gives the input cell each facet was taken
 * from.
 *
 * Input: a vtkUnstructuredGrid of only tetrahedra or only triangles in a plane (the output of
 * stmSpacetreeTessellate with Simplicial output, stmMarchingSimplices or stmBoundarySmooth),
 * with the cell array "Material" (without it, every cell is one material that is not the
 * background, and only the outer boundary is written). The facets and their order do not
 * depend on the number of threads (see Filters/Core/Surface/InterfaceFacets.h).
 *
 * @sa stmMarchingSimplices stmBoundarySmooth
 */

#ifndef stmInterfaceSurface_h
#define stmInterfaceSurface_h

#include "SpacetreeMeshFiltersModule.h" // for export macro
#include "vtkPolyDataAlgorithm.h"

class SPACETREEMESHFILTERS_EXPORT stmInterfaceSurface : public vtkPolyDataAlgorithm
{
public:
  static stmInterfaceSurface* New();
  vtkTypeMacro(stmInterfaceSurface, vtkPolyDataAlgorithm);
  void PrintSelf(ostream& os, vtkIndent indent) override;

  ///@{
  /**
   * Also write the outer-boundary facets of cells that are not BackgroundMaterial, labelled
   * OuterLabel outside. Default on.
   */
  vtkSetMacro(IncludeOuterBoundary, vtkTypeBool);
  vtkGetMacro(IncludeOuterBoundary, vtkTypeBool);
  vtkBooleanMacro(IncludeOuterBoundary, vtkTypeBool);
  ///@}

  ///@{
  /**
   * The "Material" of the background, whose outer-boundary facets are never written. Default 0.
   */
  vtkSetMacro(BackgroundMaterial, int);
  vtkGetMacro(BackgroundMaterial, int);
  ///@}

  ///@{
  /**
   * The label of the outside of the mesh in BoundaryLabels. Default -1.
   */
  vtkSetMacro(OuterLabel, int);
  vtkGetMacro(OuterLabel, int);
  ///@}

protected:
  stmInterfaceSurface() = default;
  ~stmInterfaceSurface() override = default;

  int FillInputPortInformation(int port, vtkInformation* info) override;
  int RequestData(vtkInformation* request, vtkInformationVector** inputVector,
    vtkInformationVector* outputVector) override;

private:
  stmInterfaceSurface(const stmInterfaceSurface&) = delete;
  void operator=(const stmInterfaceSurface&) = delete;

  vtkTypeBool IncludeOuterBoundary = 1;
  int BackgroundMaterial = 0;
  int OuterLabel = -1;
};

#endif
