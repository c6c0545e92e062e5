// SPDX-License-Identifier: BSD-3-Clause
#include "stmSpacetreeBalance.h"

#include "stmSMPExecutor.h"
#include "stmSpacetreeData.h"

#include "Balance/SpacetreeBalance.h"

#include "vtkInformation.h"
#include "vtkInformationVector.h"
#include "vtkObjectFactory.h"
#include "vtkUnstructuredGrid.h"

vtkStandardNewMacro(stmSpacetreeBalance);

namespace
{
template <int Dim>
bool Balance(vtkUnstructuredGrid* input, const stmSpacetreeGeometry& geometry,
  const stm::SpacetreeBalanceOptions& options, stmSMPExecutor& executor,
  vtkUnstructuredGrid* output, std::string& error)
{
  stm::Spacetree<Dim> tree;
  if (!stmSpacetreeData::ReadSpacetree<Dim>(input, tree, error))
  {
    return false;
  }
  executor.ReportProgress(0.1);
  const stm::Status status = stm::SpacetreeBalancer<Dim>().Balance(tree, options, executor);
  if (!status.IsOk())
  {
    error = status.GetMessage();
    return false;
  }
  stmSpacetreeData::WriteSpacetree<Dim>(tree, geometry, output);
  return true;
}
} // namespace

stmSpacetreeBalance::stmSpacetreeBalance() = default;
stmSpacetreeBalance::~stmSpacetreeBalance() = default;

void stmSpacetreeBalance::PrintSelf(ostream& os, vtkIndent indent)
{
  this->Superclass::PrintSelf(os, indent);
  os << indent << "BalanceLevel: " << this->BalanceLevel << "\n";
  os << indent << "FaceBalanceOnly: " << (this->FaceBalanceOnly ? "On" : "Off") << "\n";
}

int stmSpacetreeBalance::RequestData(
  vtkInformation*, vtkInformationVector** inputVector, vtkInformationVector* outputVector)
{
  vtkUnstructuredGrid* output = vtkUnstructuredGrid::GetData(outputVector, 0);
  vtkUnstructuredGrid* input = nullptr;
  stmSpacetreeGeometry geometry;
  int requestResult = 0;
  if (!stmSpacetreeData::BeginRequest(this, inputVector[0], output, input, geometry, requestResult))
  {
    return requestResult;
  }
  std::string error;
  stm::SpacetreeBalanceOptions options;
  options.BalanceLevel = this->BalanceLevel;
  options.FaceBalanceOnly = this->FaceBalanceOnly;
  stmSMPExecutor executor(this);
  const bool balanced = geometry.Dimension == 3
    ? Balance<3>(input, geometry, options, executor, output, error)
    : Balance<2>(input, geometry, options, executor, output, error);
  return stmSpacetreeData::EndRequest(this, balanced, error, output);
}
