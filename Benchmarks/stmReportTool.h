// SPDX-License-Identifier: BSD-3-Clause
// What the report generators of Benchmarks/ share: their command line, their number format and
// where the report goes.

#ifndef stmReportTool_h
#define stmReportTool_h

#include <cstring>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <sstream>
#include <string>

namespace stmReport
{

/// Reads "--input FILE" and "--output FILE" (both optional; input keeps its default, an empty
/// output means standard output). Anything else prints the usage and returns false.
inline bool ParseArguments(
  int argc, char* argv[], const char* usage, std::string& input, std::string& output)
{
  for (int i = 1; i < argc; i += 2)
  {
    if (i + 1 < argc && std::strcmp(argv[i], "--input") == 0)
    {
      input = argv[i + 1];
    }
    else if (i + 1 < argc && std::strcmp(argv[i], "--output") == 0)
    {
      output = argv[i + 1];
    }
    else
    {
      std::cerr << "usage: " << usage << "\n";
      return false;
    }
  }
  return true;
}

/// Writes the report to the output file, or to standard output if it is empty; false if the file
/// could not be written.
inline bool WriteReport(const std::string& report, const std::string& output)
{
  if (output.empty())
  {
    std::cout << report;
    return true;
  }
  std::ofstream file(output);
  file << report;
  return file.good();
}

/// Thousands separated by commas, as in the prose.
inline std::string Count(long long value)
{
  std::string digits = std::to_string(value < 0 ? -value : value);
  for (int i = static_cast<int>(digits.size()) - 3; i > 0; i -= 3)
  {
    digits.insert(static_cast<std::size_t>(i), ",");
  }
  return (value < 0 ? "-" : "") + digits;
}

inline std::string Fixed(double value, int precision)
{
  std::ostringstream text;
  text << std::fixed << std::setprecision(precision) << value;
  return text.str();
}

} // namespace stmReport

#endif
