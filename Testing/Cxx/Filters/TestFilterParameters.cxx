// SPDX-License-Identifier: BSD-3-Clause
// Parameters of the filters: documented defaults, clamped ranges, and PrintSelf listing each
// one (the plugin XML defaults are compared with these in Testing/Python).

#include "stmImageToSpacetree.h"
#include "stmSpacetreeBalance.h"
#include "stmSpacetreeTessellate.h"

#include "vtkNew.h"

#include <gtest/gtest.h>

#include <sstream>
#include <string>

namespace
{
template <class Filter>
std::string Printed(Filter* filter)
{
  std::ostringstream out;
  filter->Print(out);
  return out.str();
}

TEST(FilterParameters, ImageToSpacetree)
{
  vtkNew<stmImageToSpacetree> filter;
  EXPECT_EQ(filter->GetMaxCellSize(), 16);
  EXPECT_EQ(filter->GetBackgroundLabel(), 0);
  EXPECT_EQ(filter->GetNumberOfBodyLabels(), 0);
  filter->SetMaxCellSize(0);
  EXPECT_EQ(filter->GetMaxCellSize(), 1);
  filter->SetMaxCellSize(1 << 30);
  EXPECT_EQ(filter->GetMaxCellSize(), 1 << 20);
  filter->SetBodyLabel(2, 7);
  EXPECT_EQ(filter->GetNumberOfBodyLabels(), 3);
  EXPECT_EQ(filter->GetBodyLabel(2), 7);
  filter->AddBodyLabel(9);
  EXPECT_EQ(filter->GetBodyLabel(3), 9);
  filter->RemoveAllBodyLabels();
  EXPECT_EQ(filter->GetNumberOfBodyLabels(), 0);
  EXPECT_EQ(std::string(filter->GetRefinementPattern()), "auto");
  EXPECT_EQ(filter->GetRootCellSize()[0], 0);
  EXPECT_EQ(filter->GetRootCellSize()[2], 0);
  EXPECT_EQ(filter->GetNumberOfLabelMaxCellSizes(), 0);
  EXPECT_EQ(filter->GetRefinementRegion(), nullptr);
  EXPECT_EQ(filter->GetRegionMaxCellSize(), 0.0);
  EXPECT_EQ(filter->GetRegionBandWidth(), 0.0);
  EXPECT_EQ(filter->GetGrading(), 0.0);
  EXPECT_FALSE(filter->GetUseSizingArray());
  filter->SetRegionBandWidth(-1);
  EXPECT_EQ(filter->GetRegionBandWidth(), 0.0);
  filter->SetLabelMaxCellSize(3, 2);
  filter->SetLabelMaxCellSize(3, 4);
  EXPECT_EQ(filter->GetNumberOfLabelMaxCellSizes(), 1);
  const std::string printed = Printed(filter.Get());
  for (const char* name : { "BodyLabels", "BackgroundLabel", "MaxCellSize", "RefinementPattern",
         "RootCellSize", "LabelMaxCellSizes: 3:4", "RefinementRegion", "RegionMaxCellSize",
         "RegionBandWidth", "Grading", "UseSizingArray" })
  {
    EXPECT_NE(printed.find(name), std::string::npos) << name;
  }
}

TEST(FilterParameters, SpacetreeBalance)
{
  vtkNew<stmSpacetreeBalance> filter;
  EXPECT_EQ(filter->GetBalanceLevel(), 1);
  EXPECT_FALSE(filter->GetFaceBalanceOnly());
  filter->SetBalanceLevel(0);
  EXPECT_EQ(filter->GetBalanceLevel(), 1);
  filter->SetBalanceLevel(99);
  EXPECT_EQ(filter->GetBalanceLevel(), 20);
  EXPECT_EQ(filter->GetNumberOfLabelBalanceLevels(), 0);
  EXPECT_EQ(filter->GetBalanceRegion(), nullptr);
  EXPECT_EQ(filter->GetRegionBalanceLevel(), 0);
  filter->SetRegionBalanceLevel(21);
  EXPECT_EQ(filter->GetRegionBalanceLevel(), 20);
  filter->SetLabelBalanceLevel(4, 2);
  EXPECT_EQ(filter->GetNumberOfLabelBalanceLevels(), 1);
  const std::string printed = Printed(filter.Get());
  for (const char* name : { "BalanceLevel", "FaceBalanceOnly", "LabelBalanceLevels: 4:2",
         "BalanceRegion", "RegionBalanceLevel" })
  {
    EXPECT_NE(printed.find(name), std::string::npos) << name;
  }
}

TEST(FilterParameters, SpacetreeTessellate)
{
  vtkNew<stmSpacetreeTessellate> filter;
  EXPECT_EQ(filter->GetCellTemplate(), stmSpacetreeTessellate::CHECKERBOARD);
  EXPECT_FALSE(filter->GetIncludeBackground());
  filter->SetCellTemplate(5);
  EXPECT_EQ(filter->GetCellTemplate(), stmSpacetreeTessellate::KUHN);
  const std::string printed = Printed(filter.Get());
  for (const char* name : { "CellTemplate", "IncludeBackground" })
  {
    EXPECT_NE(printed.find(name), std::string::npos) << name;
  }
}
} // namespace
