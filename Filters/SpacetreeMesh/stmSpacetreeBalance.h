// SPDX-License-Identifier: BSD-3-Clause
/**
 * @class   stmSpacetreeBalance
 * @brief   limit the level difference between adjacent spacetree leaves
 *
 * stmSpacetreeBalance takes the spacetree produced by stmImageToSpacetree and splits leaves
 * until no two adjacent leaves differ by more than BalanceLevel levels (paper section 2.2).
 * Leaves are adjacent when they share a vertex, or only when they share a facet if
 * FaceBalanceOnly is on. It only refines: it never coarsens a leaf and never changes a
 * material. The output has the same representation as the input. A lower BalanceLevel gives
 * better-shaped elements after tessellation (BalanceLevel 1 gives the best); a higher one,
 * fewer leaves.
 *
 * The balance level may vary: per label (LabelBalanceLevels) and inside a region (an implicit
 * function, value <= 0 at the leaf centre), which overrides the label's. Two adjacent leaves
 * must satisfy the smaller of their two levels.
 *
 * @sa stmImageToSpacetree stmSpacetreeTessellate
 */

#ifndef stmSpacetreeBalance_h
#define stmSpacetreeBalance_h

#include "SpacetreeMeshFiltersModule.h" // for export macro
#include "vtkUnstructuredGridAlgorithm.h"

#include <map> // for the per-label levels

class vtkImplicitFunction;

class SPACETREEMESHFILTERS_EXPORT stmSpacetreeBalance : public vtkUnstructuredGridAlgorithm
{
public:
  static stmSpacetreeBalance* New();
  vtkTypeMacro(stmSpacetreeBalance, vtkUnstructuredGridAlgorithm);
  void PrintSelf(ostream& os, vtkIndent indent) override;

  ///@{
  /**
   * Largest level difference allowed between adjacent leaves. Default 1, range 1 to 20.
   */
  vtkSetClampMacro(BalanceLevel, int, 1, 20);
  vtkGetMacro(BalanceLevel, int);
  ///@}

  ///@{
  /**
   * Only leaves sharing a facet count as adjacent (otherwise also edge and vertex
   * neighbours). Default off.
   */
  vtkSetMacro(FaceBalanceOnly, bool);
  vtkGetMacro(FaceBalanceOnly, bool);
  vtkBooleanMacro(FaceBalanceOnly, bool);
  ///@}

  ///@{
  /**
   * Balance level (1 to 20) of the leaves of a body label, instead of BalanceLevel. Every
   * listed label must be a body label of the spacetree.
   */
  void SetLabelBalanceLevel(double label, double level);
  void RemoveAllLabelBalanceLevels();
  int GetNumberOfLabelBalanceLevels() const;
  ///@}

  ///@{
  /**
   * A region (implicit function; inside where its value at a leaf centre is <= 0) with its own
   * balance level, RegionBalanceLevel. Default: none.
   */
  virtual void SetBalanceRegion(vtkImplicitFunction* region);
  vtkGetObjectMacro(BalanceRegion, vtkImplicitFunction);
  ///@}

  ///@{
  /**
   * Balance level inside BalanceRegion; 0 (the default) disables the region, otherwise 1 to 20.
   */
  vtkSetClampMacro(RegionBalanceLevel, int, 0, 20);
  vtkGetMacro(RegionBalanceLevel, int);
  ///@}

  vtkMTimeType GetMTime() override;

protected:
  stmSpacetreeBalance();
  ~stmSpacetreeBalance() override;

  int RequestData(vtkInformation* request, vtkInformationVector** inputVector,
    vtkInformationVector* outputVector) override;

  int BalanceLevel = 1;
  bool FaceBalanceOnly = false;
  std::map<int, int> LabelBalanceLevels;
  vtkImplicitFunction* BalanceRegion = nullptr;
  int RegionBalanceLevel = 0;

private:
  stmSpacetreeBalance(const stmSpacetreeBalance&) = delete;
  void operator=(const stmSpacetreeBalance&) = delete;
};

#endif
