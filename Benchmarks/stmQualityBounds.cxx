// SPDX-License-Identifier: BSD-3-Clause
// Writes docs/quality-bounds.md: for every element shape the tessellation can produce at balance
// levels 1 to 4 with the 2^d, 3^d and 2x2x1 refinement patterns (enumerated by
// Tessellate/ElementShapeEnumeration.h), the worst Verdict quality, per dimension and variant.
// With --check, compares the file with what it would write instead and fails on a difference.
//
//   stmQualityBounds [--output docs/quality-bounds.md | --check docs/quality-bounds.md]

#include "stmQualityBounds.h"
#include "stmReportTool.h"

#include <cstring>
#include <fstream>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

int main(int argc, char* argv[])
{
  std::string output, check;
  for (int i = 1; i + 1 < argc; i += 2)
  {
    if (std::strcmp(argv[i], "--output") == 0)
    {
      output = argv[i + 1];
    }
    else if (std::strcmp(argv[i], "--check") == 0)
    {
      check = argv[i + 1];
    }
    else
    {
      std::cerr << "usage: stmQualityBounds [--output FILE | --check FILE]\n";
      return 2;
    }
  }
  std::vector<stmTest::BoundRow> rows;
  const stm::Status status = stmTest::ComputeAllBounds(rows);
  if (!status.IsOk())
  {
    std::cerr << "stmQualityBounds: " << status.GetMessage() << "\n";
    return 1;
  }
  const std::string report = stmTest::QualityBoundsReport(rows);
  if (!check.empty())
  {
    std::ifstream file(check);
    std::ostringstream committed;
    committed << file.rdbuf();
    if (committed.str() != report)
    {
      std::cerr << "stmQualityBounds: " << check
                << " differs from the generated report; regenerate it with --output\n";
      return 1;
    }
    return 0;
  }
  return stmReport::WriteReport(report, output) ? 0 : 1;
}
