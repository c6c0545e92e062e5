// SPDX-License-Identifier: BSD-3-Clause
#ifndef stmCoreLabelTable_h
#define stmCoreLabelTable_h

// Label tables: the names of an atlas's labels, as the files beside the atlases list them.
// One label per line, its integer value first; the name is the first double-quoted text on
// the line (ITK-SNAP's label descriptions) or else the second word (MRIcron's .txt files:
// "1 Precentral_L 2001"; FreeSurfer's colour tables: "17 Left-Hippocampus 220 216 20 0").
// Blank lines and lines starting with '#' are skipped; anything else is an error naming the
// line, as is a label given twice.

#include "../Common/Status.h"
#include "MeshExport.h"

#include <cerrno>
#include <cstdlib>
#include <istream>
#include <set>
#include <sstream>
#include <string>
#include <vector>

namespace stm
{

inline Status ParseLabelTable(std::istream& in, std::vector<MaterialName>& names)
{
  names.clear();
  std::set<std::int64_t> seen;
  std::string line;
  for (int number = 1; std::getline(in, line); ++number)
  {
    if (!line.empty() && line.back() == '\r')
    {
      line.pop_back();
    }
    const std::size_t first = line.find_first_not_of(" \t");
    if (first == std::string::npos || line[first] == '#')
    {
      continue;
    }
    std::istringstream words(line.substr(first));
    std::string labelWord;
    words >> labelWord;
    char* end = nullptr;
    errno = 0;
    const long long label = std::strtoll(labelWord.c_str(), &end, 10);
    if (labelWord.empty() || *end != '\0' || errno == ERANGE)
    {
      return Status::Invalid("line " + std::to_string(number) +
        " of the label table does not "
        "start with an integer label: '" +
        line + "'");
    }
    std::string name;
    const std::size_t open = line.find('"');
    const std::size_t close = open == std::string::npos ? open : line.find('"', open + 1);
    if (open != std::string::npos && close != std::string::npos)
    {
      name = line.substr(open + 1, close - open - 1);
    }
    else
    {
      words >> name;
    }
    if (name.empty())
    {
      return Status::Invalid(
        "line " + std::to_string(number) + " of the label table has no name: '" + line + "'");
    }
    if (!seen.insert(label).second)
    {
      return Status::Invalid("label " + std::to_string(label) +
        " is named twice in the label "
        "table (line " +
        std::to_string(number) + ")");
    }
    names.push_back({ label, name });
  }
  if (in.bad())
  {
    return Status::Invalid("reading the label table failed");
  }
  return Status::Ok();
}

} // namespace stm

#endif
