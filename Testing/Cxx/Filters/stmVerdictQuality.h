// SPDX-License-Identifier: BSD-3-Clause
// The two Verdict figures SpacetreeMesh reports and bounds, measured by vtkMeshQuality: shared by
// the quality tests and the report generator (Benchmarks/stmElementQuality.cxx).

#ifndef stmVerdictQuality_h
#define stmVerdictQuality_h

#include "vtkCellData.h"
#include "vtkCellType.h"
#include "vtkDataArray.h"
#include "vtkDataSet.h"
#include "vtkIdList.h"
#include "vtkMeshQuality.h"
#include "vtkNew.h"

#include "Check/SimplexQuality.h"

#include <algorithm>
#include <utility>

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
  vtkDataArray* angles =
    vtkDataSet::SafeDownCast(angle->GetOutput())->GetCellData()->GetArray("Quality");
  // VTK 9.2's tetrahedron minimum angle is not the smallest dihedral angle for every vertex
  // order (it takes 180 degrees minus the angles at edges 0-2 and 1-3): tetrahedra are measured
  // by the core's MeasureSimplex instead; triangles keep Verdict's (correct) smallest angle.
  vtkNew<vtkIdList> ids;
  for (vtkIdType cell = 0; cell < mesh->GetNumberOfCells(); ++cell)
  {
    if (mesh->GetCellType(cell) != VTK_TETRA)
    {
      range.SmallestAngle = std::min(range.SmallestAngle, angles->GetTuple1(cell));
      continue;
    }
    mesh->GetCellPoints(cell, ids);
    double x[4][3];
    const double* corners[4];
    for (int k = 0; k < 4; ++k)
    {
      mesh->GetPoint(ids->GetId(k), x[k]);
      corners[k] = x[k];
    }
    const stm::SimplexShape<3> shape = stm::MeasureSimplex<3>(corners);
    if (shape.Determinant < 0)
    {
      std::swap(corners[0], corners[1]);
    }
    range.SmallestAngle =
      std::min(range.SmallestAngle, stm::MeasureSimplex<3>(corners).MinDihedralDegrees);
  }
  return range;
}

} // namespace stmTest

#endif
