// SPDX-License-Identifier: BSD-3-Clause
#include "stmSpacetreeBalance.h"

#include "stmSMPExecutor.h"
#include "stmSpacetreeData.h"

#include "Balance/SpacetreeBalance.h"

#include "vtkImplicitFunction.h"
#include "vtkInformation.h"
#include "vtkInformationVector.h"
#include "vtkObjectFactory.h"
#include "vtkUnstructuredGrid.h"

#include <algorithm>
#include <string>

vtkStandardNewMacro(stmSpacetreeBalance);

namespace
{
template <int Dim>
bool Balance(vtkUnstructuredGrid* input, const stmSpacetreeGeometry& geometry,
  stm::SpacetreeBalanceOptions options, const std::map<int, int>& labelLevels,
  stmSMPExecutor& executor, vtkUnstructuredGrid* output, std::string& error)
{
  stm::Spacetree<Dim> tree;
  if (!stmSpacetreeData::ReadSpacetree<Dim>(input, tree, error) || executor.ShouldAbort())
  {
    return false;
  }
  if (!labelLevels.empty())
  {
    options.MaterialBalanceLevels.assign(tree.MaterialLabels.size(), 0);
    for (const auto& entry : labelLevels)
    {
      const auto found =
        std::find(tree.MaterialLabels.begin() + 1, tree.MaterialLabels.end(), entry.first);
      if (found == tree.MaterialLabels.end())
      {
        error = "LabelBalanceLevels names label " + std::to_string(entry.first) +
          ", which is not a body label of the spacetree";
        return false;
      }
      if (entry.second < 1 || entry.second > 20)
      {
        error = "the balance level of label " + std::to_string(entry.first) +
          " must be between 1 and 20, got " + std::to_string(entry.second);
        return false;
      }
      options.MaterialBalanceLevels[found - tree.MaterialLabels.begin()] = entry.second;
    }
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

stmSpacetreeBalance::~stmSpacetreeBalance()
{
  this->SetBalanceRegion(nullptr);
}

vtkCxxSetObjectMacro(stmSpacetreeBalance, BalanceRegion, vtkImplicitFunction);

vtkMTimeType stmSpacetreeBalance::GetMTime()
{
  vtkMTimeType time = this->Superclass::GetMTime();
  if (this->BalanceRegion)
  {
    time = std::max(time, this->BalanceRegion->GetMTime());
  }
  return time;
}

void stmSpacetreeBalance::SetLabelBalanceLevel(double label, double level)
{
  const int key = static_cast<int>(label);
  const int value = static_cast<int>(level);
  const auto found = this->LabelBalanceLevels.find(key);
  if (found == this->LabelBalanceLevels.end() || found->second != value)
  {
    this->LabelBalanceLevels[key] = value;
    this->Modified();
  }
}

void stmSpacetreeBalance::RemoveAllLabelBalanceLevels()
{
  if (!this->LabelBalanceLevels.empty())
  {
    this->LabelBalanceLevels.clear();
    this->Modified();
  }
}

int stmSpacetreeBalance::GetNumberOfLabelBalanceLevels() const
{
  return static_cast<int>(this->LabelBalanceLevels.size());
}

void stmSpacetreeBalance::PrintSelf(ostream& os, vtkIndent indent)
{
  this->Superclass::PrintSelf(os, indent);
  os << indent << "BalanceLevel: " << this->BalanceLevel << "\n";
  os << indent << "FaceBalanceOnly: " << (this->FaceBalanceOnly ? "On" : "Off") << "\n";
  os << indent << "LabelBalanceLevels:";
  for (const auto& entry : this->LabelBalanceLevels)
  {
    os << " " << entry.first << ":" << entry.second;
  }
  os << (this->LabelBalanceLevels.empty() ? " (none)\n" : "\n");
  os << indent
     << "BalanceRegion: " << (this->BalanceRegion ? this->BalanceRegion->GetClassName() : "(none)")
     << "\n";
  os << indent << "RegionBalanceLevel: " << this->RegionBalanceLevel << "\n";
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
  if (this->BalanceRegion && this->RegionBalanceLevel > 0)
  {
    vtkImplicitFunction* region = this->BalanceRegion;
    const int level = this->RegionBalanceLevel;
    options.RegionBalanceLevel = [region, level, geometry](const double* centre)
    {
      double x[3];
      geometry.ToPhysical(centre, x);
      return region->FunctionValue(x) <= 0 ? level : 0;
    };
  }
  stmSMPExecutor executor(this);
  const bool balanced = geometry.Dimension == 3
    ? Balance<3>(input, geometry, options, this->LabelBalanceLevels, executor, output, error)
    : Balance<2>(input, geometry, options, this->LabelBalanceLevels, executor, output, error);
  return stmSpacetreeData::EndRequest(this, balanced, error, output);
}
