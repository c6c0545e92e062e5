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
 * @sa stmImageToSpacetree stmSpacetreeTessellate
 */

#ifndef stmSpacetreeBalance_h
#define stmSpacetreeBalance_h

#include "SpacetreeMeshFiltersModule.h" // for export macro
#include "vtkUnstructuredGridAlgorithm.h"

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

protected:
  stmSpacetreeBalance();
  ~stmSpacetreeBalance() override;

  int RequestData(vtkInformation* request, vtkInformationVector** inputVector,
    vtkInformationVector* outputVector) override;

  int BalanceLevel = 1;
  bool FaceBalanceOnly = false;

private:
  stmSpacetreeBalance(const stmSpacetreeBalance&) = delete;
  void operator=(const stmSpacetreeBalance&) = delete;
};

#endif
