// SPDX-License-Identifier: BSD-3-Clause
/**
 * @class   stmImageToSpacetree
 * @brief   build the spacetree of a segmented (label) image
 *
 * stmImageToSpacetree is the first stage of the SpacetreeMesh pipeline. It reads an integer label
 * array of a 2D or 3D vtkImageData (point or cell scalars; a point-data image has one voxel per
 * point, centred on it) and builds the spacetree of the paper's section 2.1: a root grid of
 * power-of-two cells no larger than MaxCellSize voxels that covers the image (padded with
 * background), refined with the 2^d pattern while a cell holds more than one material. A
 * material is a label of the body of interest, or the background for every other label and
 * the padding. Every material interface is therefore resolved at voxel size.
 *
 * The output is a vtkUnstructuredGrid with one hexahedron (quad in 2D) per leaf and the cell
 * arrays "Level" (0 = root), "Material" (the label, or BackgroundLabel outside the body) and
 * "LatticeIndex" (the leaf's integer position at its level), plus field data that describe the
 * root grid, the image geometry and the body labels, so that stmSpacetreeBalance and
 * stmSpacetreeTessellate (or a file written and read back) rebuild the tree exactly.
 * Spacing, origin and direction matrix of the image are respected.
 *
 * Reference: "Image-based unstructured 3D mesh generation for medical applications",
 * section 2.1 (the specification of SpacetreeMesh).
 *
 * @sa stmSpacetreeBalance stmSpacetreeTessellate
 */

#ifndef stmImageToSpacetree_h
#define stmImageToSpacetree_h

#include "SpacetreeMeshFiltersModule.h" // for export macro
#include "vtkUnstructuredGridAlgorithm.h"

#include <vector> // for the body labels

class SPACETREEMESHFILTERS_EXPORT stmImageToSpacetree : public vtkUnstructuredGridAlgorithm
{
public:
  static stmImageToSpacetree* New();
  vtkTypeMacro(stmImageToSpacetree, vtkUnstructuredGridAlgorithm);
  void PrintSelf(ostream& os, vtkIndent indent) override;

  /**
   * Whether arrays of this VTK data type (VTK_INT, ...) can hold labels: the integer types.
   */
  static bool IsLabelType(int dataType);

  ///@{
  /**
   * The labels that form the body of interest. Empty (the default) means every label present
   * in the image except BackgroundLabel. Every listed label must occur in the image.
   */
  void SetNumberOfBodyLabels(int count);
  int GetNumberOfBodyLabels() const;
  void SetBodyLabel(int index, int label);
  int GetBodyLabel(int index) const;
  void AddBodyLabel(int label);
  void RemoveAllBodyLabels();
  ///@}

  ///@{
  /**
   * The label given to leaves outside the body of interest (and to the padding of the root
   * grid). Default 0. It may not be one of the body labels.
   */
  vtkSetMacro(BackgroundLabel, int);
  vtkGetMacro(BackgroundLabel, int);
  ///@}

  ///@{
  /**
   * Largest leaf edge, in voxels; the root cells are the largest power of two not above it
   * (and no larger than needed to cover the image). Default 16, range 1 to 2^20.
   */
  vtkSetClampMacro(MaxCellSize, int, 1, 1 << 20);
  vtkGetMacro(MaxCellSize, int);
  ///@}

protected:
  stmImageToSpacetree();
  ~stmImageToSpacetree() override;

  int FillInputPortInformation(int port, vtkInformation* info) override;
  int RequestData(vtkInformation* request, vtkInformationVector** inputVector,
    vtkInformationVector* outputVector) override;

  std::vector<int> BodyLabels;
  int BackgroundLabel = 0;
  int MaxCellSize = 16;

private:
  stmImageToSpacetree(const stmImageToSpacetree&) = delete;
  void operator=(const stmImageToSpacetree&) = delete;
};

#endif
