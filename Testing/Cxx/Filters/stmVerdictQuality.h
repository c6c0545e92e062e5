// SPDX-License-Identifier: BSD-3-Clause
// The two Verdict figures SpacetreeMesh reports and bounds, measured by vtkMeshQuality: shared by
// the quality tests and the report generator (Benchmarks/stmElementQuality.cxx).

#ifndef stmVerdictQuality_h
#define stmVerdictQuality_h

#include "vtkCellData.h"
#include "vtkDataArray.h"
#include "vtkDataSet.h"
#include "vtkMeshQuality.h"
#include "vtkNew.h"

namespace stmTest
{

struct VerdictQualityRange
{
  /// Largest condition number (1 is the equilateral simplex).
  double WorstCondition = 0.0;
  /// Smallest dihedral angle of a tetrahedron, or smallest angle of a triangle, in degrees.
  double SmallestAngle = 180.0;
};

inline VerdictQualityRange MeasureVerdictQuality(vtkDataSet* mesh)
{
  VerdictQualityRange range;
  if (mesh->GetNumberOfCells() == 0)
  {
    return range;
  }
  vtkNew<vtkMeshQuality> condition;
  condition->SetInputData(mesh);
  condition->SetTetQualityMeasureToCondition();
  condition->SetTriangleQualityMeasureToCondition();
  condition->Update();
  range.WorstCondition = vtkDataSet::SafeDownCast(condition->GetOutput())
                           ->GetCellData()
                           ->GetArray("Quality")
                           ->GetRange()[1];
  vtkNew<vtkMeshQuality> angle;
  angle->SetInputData(mesh);
  angle->SetTetQualityMeasureToMinAngle();
  angle->SetTriangleQualityMeasureToMinAngle();
  angle->Update();
  range.SmallestAngle =
    vtkDataSet::SafeDownCast(angle->GetOutput())->GetCellData()->GetArray("Quality")->GetRange()[0];
  return range;
}

} // namespace stmTest

#endif
