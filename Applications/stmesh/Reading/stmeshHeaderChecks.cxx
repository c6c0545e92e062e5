// SPDX-License-Identifier: BSD-3-Clause
#include "stmeshHeaderChecks.h"

#include "stmeshErrors.h"
#include "stmeshText.h"

#include "stmNIFTIHeader.h" // shared with the plugin's NIfTI reader

#include <sys/stat.h>

#include <algorithm>
#include <cerrno>
#include <cstdint>
#include <cstdlib>
#include <fstream>
#include <iomanip>
#include <iterator>
#include <sstream>
#include <vector>

namespace stmesh
{

namespace
{

/// A data file named by a detached header: absolute, or relative to the header's folder.
std::string DataFileBeside(const std::string& headerPath, const std::string& name)
{
  const std::size_t slash = headerPath.find_last_of('/');
  return name[0] == '/' || slash == std::string::npos ? name
                                                      : headerPath.substr(0, slash + 1) + name;
}

bool IsReadableFile(const std::string& path)
{
  struct stat info;
  return stat(path.c_str(), &info) == 0 && !S_ISDIR(info.st_mode);
}

/// The whole token as an integer (no sign for sizes is checked by the caller).
bool ParseInteger(const std::string& token, long long& value)
{
  char* end = nullptr;
  errno = 0;
  value = std::strtoll(token.c_str(), &end, 10);
  return !token.empty() && end && *end == '\0' && errno == 0;
}

/// The whole token as a number ("nan" and "inf" included, as strtod reads them).
bool ParseNumber(const std::string& token, double& value)
{
  char* end = nullptr;
  value = std::strtod(token.c_str(), &end);
  return !token.empty() && end && *end == '\0';
}

std::vector<std::string> Tokens(const std::string& text)
{
  std::istringstream stream(text);
  return std::vector<std::string>(
    std::istream_iterator<std::string>(stream), std::istream_iterator<std::string>());
}

/// "(x,y,z)" with `count` numbers.
bool ParseVector(const std::string& token, std::size_t count, std::vector<double>& values)
{
  values.clear();
  if (token.size() < 2 || token.front() != '(' || token.back() != ')')
  {
    return false;
  }
  std::istringstream parts(token.substr(1, token.size() - 2));
  std::string part;
  while (std::getline(parts, part, ','))
  {
    double value = 0.0;
    if (!ParseNumber(Trim(part), value))
    {
      return false;
    }
    values.push_back(value);
  }
  return values.size() == count;
}

/// A file pattern VTK expands with snprintf(format, i): exactly one integer conversion
/// (flags and width allowed), no other conversion but "%%".
bool IsIntegerFilePattern(const std::string& format)
{
  int conversions = 0;
  for (std::size_t i = 0; i < format.size(); ++i)
  {
    if (format[i] != '%')
    {
      continue;
    }
    if (i + 1 < format.size() && format[i + 1] == '%')
    {
      ++i;
      continue;
    }
    std::size_t j = i + 1;
    while (j < format.size() && std::string("-+ #0").find(format[j]) != std::string::npos)
    {
      ++j;
    }
    std::size_t digits = 0;
    while (j < format.size() && format[j] >= '0' && format[j] <= '9' && digits < 3)
    {
      ++j;
      ++digits;
    }
    if (j >= format.size() || std::string("diuxXo").find(format[j]) == std::string::npos)
    {
      return false;
    }
    ++conversions;
    i = j;
  }
  return conversions == 1;
}

} // namespace

void CheckNiftiHeader(const std::string& path, const std::string& context)
{
  const std::string problem = stm::NIFTIHeaderProblem(path);
  if (!problem.empty())
  {
    throw Failure(context + ": " + problem);
  }
}

void CheckMetaImageHeader(const std::string& path, const std::string& context)
{
  // The keys that size the voxels VTK allocates and MetaIO reads. MetaIO overflows VTK's
  // buffer when they disagree (found by FuzzImageReading: NDims given twice, a DimSize of
  // more numbers than NDims, three channels), so each may appear once, NDims first, with
  // DimSize and ElementSpacing one number per axis and a single channel.
  static const char* const SizingKeys[] = { "NDims", "DimSize", "ElementSpacing", "ElementSize",
    "ElementNumberOfChannels", "ElementType", "ElementDataFile", "HeaderSize", "CompressedData",
    "CompressedDataSize", "BinaryData", "ElementByteOrderMSB", "BinaryDataByteOrderMSB" };
  std::ifstream file(path, std::ios::binary);
  std::string line;
  long long dimensions = 0;
  std::string dataFile;
  std::vector<std::string> seen;
  for (int lines = 0; lines < 1000 && dataFile.empty() && std::getline(file, line); ++lines)
  {
    const std::size_t equals = line.find('=');
    if (equals == std::string::npos)
    {
      continue;
    }
    const std::string key = Trim(line.substr(0, equals));
    const std::string value = Trim(line.substr(equals + 1));
    if (std::find(std::begin(SizingKeys), std::end(SizingKeys), key) == std::end(SizingKeys))
    {
      continue;
    }
    if (std::find(seen.begin(), seen.end(), key) != seen.end())
    {
      throw Failure(
        context + ": the MetaImage header gives " + key + " a second time (a corrupt header)");
    }
    seen.push_back(key);
    if (key == "NDims")
    {
      if (!ParseInteger(value, dimensions) || dimensions < 1 || dimensions > 3)
      {
        throw Failure(context + ": MetaImage NDims = " + value.substr(0, 20) +
          "; VTK's MetaImage reader reads 1 to 3 dimensions (write the image with at most 3 "
          "axes, or as NIfTI)");
      }
    }
    else if (key == "DimSize" || key == "ElementSpacing" || key == "ElementSize")
    {
      const std::vector<std::string> tokens = Tokens(value);
      bool valid = dimensions > 0 && static_cast<long long>(tokens.size()) == dimensions;
      for (std::size_t axis = 0; valid && axis < tokens.size(); ++axis)
      {
        long long size = 0;
        double number = 0.0;
        valid = key == "DimSize" ? ParseInteger(tokens[axis], size) && size >= 1
                                 : ParseNumber(tokens[axis], number);
      }
      if (!valid)
      {
        throw Failure(context + ": the MetaImage header's " + key + " = " + value.substr(0, 40) +
          " is not " + (dimensions > 0 ? std::to_string(dimensions) : std::string("NDims")) +
          (key == "DimSize" ? " positive integers" : " numbers") +
          (dimensions > 0 ? "" : " (NDims must come first)") + " (a corrupt header)");
      }
    }
    else if (key == "ElementNumberOfChannels" && value != "1")
    {
      throw Failure(context + ": the MetaImage header's ElementNumberOfChannels = " +
        value.substr(0, 20) + "; stmesh reads one value per voxel");
    }
    else if (key == "ElementDataFile")
    {
      dataFile = value;
    }
  }
  if (dimensions < 1)
  {
    throw Failure(context + ": the MetaImage header has no NDims (a corrupt header)");
  }
  // LOCAL: the voxels follow the header. LIST and file patterns ("%03d") name several files,
  // and MetaIO frees what it never allocated on some of those lists (found by
  // FuzzImageReading): one data file only.
  const std::string upper = ToUpper(dataFile);
  if (upper.rfind("LIST", 0) == 0 || dataFile.find('%') != std::string::npos)
  {
    throw Failure(context + ": the MetaImage header's ElementDataFile = " + dataFile.substr(0, 40) +
      " names several files; stmesh reads MetaImage voxels from one file (LOCAL or a file "
      "name)");
  }
  if (dataFile.empty() || upper == "LOCAL")
  {
    return;
  }
  const std::string data = DataFileBeside(path, dataFile);
  if (!IsReadableFile(data))
  {
    throw Failure(context + ": the MetaImage header's data file '" + data +
      "' cannot be read (ElementDataFile = " + dataFile + ")");
  }
}

void CheckNrrdHeader(const std::string& path, const std::string& context)
{
  // The fields of NRRD0001 to NRRD0005, with teem's older spellings; the second name is the
  // field the first stands for.
  static const char* const Fields[][2] = { { "type", "type" }, { "dimension", "dimension" },
    { "space dimension", "space dimension" }, { "space", "space" }, { "sizes", "sizes" },
    { "spacings", "spacings" }, { "thicknesses", "thicknesses" }, { "axis mins", "axis mins" },
    { "axismins", "axis mins" }, { "axis maxs", "axis maxs" }, { "axismaxs", "axis maxs" },
    { "centers", "centers" }, { "centerings", "centers" }, { "labels", "labels" },
    { "units", "units" }, { "kinds", "kinds" }, { "encoding", "encoding" }, { "endian", "endian" },
    { "byte skip", "byte skip" }, { "byteskip", "byte skip" }, { "line skip", "line skip" },
    { "lineskip", "line skip" }, { "data file", "data file" }, { "datafile", "data file" },
    { "content", "content" }, { "min", "min" }, { "max", "max" }, { "old min", "old min" },
    { "oldmin", "old min" }, { "old max", "old max" }, { "oldmax", "old max" },
    { "block size", "block size" }, { "blocksize", "block size" },
    { "measurement frame", "measurement frame" }, { "space directions", "space directions" },
    { "space origin", "space origin" }, { "space units", "space units" },
    { "sample units", "sample units" }, { "sampleunits", "sample units" }, { "number", "number" } };
  // The spaces of NRRD0005 that VTK reads (it refuses those with time).
  static const char* const Spaces[] = { "right-anterior-superior", "RAS", "left-anterior-superior",
    "LAS", "left-posterior-superior", "LPS", "scanner-xyz", "3D-right-handed", "3D-left-handed" };
  const std::string rewrite = " (write it with dimension 4 and sizes 1 X Y Z, or as NIfTI)";

  std::ifstream file(path, std::ios::binary);
  std::string line;
  int number = 0;
  auto corrupt = [&](const std::string& why)
  {
    return Failure(context + ": line " + std::to_string(number) + " of the NRRD header " + why +
      " (a corrupt header)");
  };
  std::vector<std::string> seen;
  // VTK's reader takes the number of axes from the last of "dimension", "space" (3) and
  // "space dimension" before "sizes" and "spacings", and as many values as that.
  long long dimension = 0;
  long long vtkAxes = 0;
  std::vector<long long> sizes;
  // The spacing VTK gives the first axis, from the later of "spacings" and "space
  // directions": 0 makes it the axis of the components.
  bool firstAxisFlat = false;
  std::string encoding;
  std::string dataFile;
  bool fileList = false;    // "LIST": the file names follow the field, one per line
  bool filePattern = false; // "format min max step"
  while (!fileList && number < 1000 && std::getline(file, line) && !line.empty())
  {
    ++number;
    if (line.find('\0') != std::string::npos)
    {
      throw corrupt("holds a zero byte");
    }
    if (number == 1)
    {
      if (line.size() != 8 || line.compare(0, 7, "NRRD000") != 0 || line[7] < '1' || line[7] > '5')
      {
        throw corrupt("is not a magic line NRRD0001 to NRRD0005");
      }
      continue;
    }
    if (line[0] == '#')
    {
      continue;
    }
    const std::size_t colon = line.find(": ");
    if (colon == std::string::npos)
    {
      if (line.find(":=") != std::string::npos)
      {
        continue; // a key/value pair
      }
      throw corrupt("is not a field 'name: value' of the format ('" + line.substr(0, 40) + "')");
    }
    const std::string name = line.substr(0, colon);
    const auto field = std::find_if(std::begin(Fields), std::end(Fields),
      [&](const char* const(&known)[2]) { return name == known[0]; });
    if (field == std::end(Fields))
    {
      throw corrupt("is not a field 'name: value' of the format ('" + line.substr(0, 40) + "')");
    }
    const std::string key = (*field)[1];
    const std::string value = Trim(line.substr(colon + 2));
    if (value.empty())
    {
      throw corrupt("gives the field '" + key + "' no value");
    }
    if (std::find(seen.begin(), seen.end(), key) != seen.end())
    {
      throw corrupt("gives the field '" + key + "' a second time");
    }
    seen.push_back(key);
    const std::vector<std::string> tokens = Tokens(value);
    if (key == "dimension" || key == "space dimension")
    {
      long long count = 0;
      if (!ParseInteger(value, count) || count < 1 || count > 16)
      {
        throw corrupt(
          "gives '" + key + "' the value '" + value.substr(0, 20) + "', not a number of axes");
      }
      if (key == "space dimension" && count != 3)
      {
        throw corrupt("gives a space dimension of " + value + "; VTK's NRRD reader reads 3");
      }
      if (key == "dimension")
      {
        dimension = count;
      }
      vtkAxes = count;
    }
    else if (key == "space")
    {
      if (std::find(std::begin(Spaces), std::end(Spaces), value) == std::end(Spaces))
      {
        throw corrupt(
          "names the space '" + value.substr(0, 40) + "', not one VTK's NRRD reader reads");
      }
      vtkAxes = 3;
    }
    else if (key == "sizes" || key == "spacings" || key == "space directions")
    {
      const long long expected = key == "space directions" ? dimension : vtkAxes;
      if (dimension == 0)
      {
        throw corrupt("gives '" + key + "' before 'dimension'");
      }
      if (static_cast<long long>(tokens.size()) != expected)
      {
        throw corrupt("gives " + std::to_string(tokens.size()) + " " + key + " where VTK's " +
          "NRRD reader reads " + std::to_string(expected) +
          " (one per axis; a 'space' or 'space dimension' field before it sets 3)");
      }
      for (std::size_t axis = 0; axis < tokens.size(); ++axis)
      {
        const std::string& token = tokens[axis];
        if (key == "sizes")
        {
          long long size = 0;
          if (!ParseInteger(token, size) || size < 1)
          {
            throw Failure(context + ": the NRRD header's sizes are not " +
              std::to_string(dimension) + " positive numbers (a corrupt header)");
          }
          sizes.push_back(size);
          continue;
        }
        double spacing = 0.0;
        std::vector<double> direction;
        const bool valid = key == "spacings" ? ParseNumber(token, spacing)
                                             : token == "none" || ParseVector(token, 3, direction);
        if (!valid)
        {
          throw corrupt("gives '" + key + "' the value '" + token.substr(0, 30) +
            "', which is not a " + (key == "spacings" ? "number" : "vector (x,y,z) or none"));
        }
        if (axis == 0)
        {
          firstAxisFlat = key == "spacings" ? spacing == 0.0
                                            : direction.empty() ||
              std::all_of(direction.begin(), direction.end(), [](double c) { return c == 0.0; });
        }
      }
    }
    else if (key == "space origin")
    {
      std::vector<double> origin;
      if (!ParseVector(value, 3, origin))
      {
        throw corrupt("gives the space origin '" + value.substr(0, 30) + "', not (x,y,z)");
      }
    }
    else if (key == "encoding")
    {
      encoding = ToLower(value);
    }
    else if (key == "data file")
    {
      if (tokens[0] == "LIST")
      {
        fileList = true;
      }
      else if (tokens.size() >= 4)
      {
        long long first = 0, last = 0, step = 0;
        if (!IsIntegerFilePattern(tokens[0]) || !ParseInteger(tokens[1], first) ||
          !ParseInteger(tokens[2], last) || !ParseInteger(tokens[3], step) || step < 1 ||
          last < first || (last - first) / step >= 100000)
        {
          throw corrupt("gives the data file pattern '" + value.substr(0, 40) +
            "', not 'format min max step' with one integer conversion and at most 100000 "
            "files");
        }
        filePattern = true;
      }
      else
      {
        dataFile = value;
      }
    }
  }
  // getline sets eof only when the last line had no line end: vtkNrrdReader never returns on
  // such a header (found by FuzzImageReading).
  if (file.eof() && !line.empty() && !fileList)
  {
    throw Failure(context + ": the NRRD header's last line '" + Trim(line).substr(0, 40) +
      "' has no line end (a truncated header)");
  }
  for (const char* required : { "type", "dimension", "sizes", "encoding" })
  {
    if (std::find(seen.begin(), seen.end(), required) == seen.end())
    {
      throw Failure(context + ": the NRRD header has no '" + std::string(required) +
        "' field (a corrupt header)");
    }
  }
  if (dimension != 3 && dimension != 4)
  {
    throw Failure(context + ": NRRD dimension " + std::to_string(dimension) +
      "; VTK's NRRD reader reads dimension 3 (X Y Z) and 4 (components X Y Z) only" + rewrite);
  }
  if (static_cast<long long>(sizes.size()) != dimension)
  {
    throw Failure(context + ": the NRRD header's sizes are not " + std::to_string(dimension) +
      " positive numbers (a corrupt header)");
  }
  if (dimension == 3 && sizes[0] < 10)
  {
    throw Failure(context + ": the NRRD image's first axis has " + std::to_string(sizes[0]) +
      " samples; VTK's NRRD reader takes a first axis of fewer than 10 for the components of "
      "a 2D image" +
      rewrite);
  }
  if (dimension == 3 && firstAxisFlat)
  {
    throw Failure(context + ": the NRRD image's first axis has no spacing (0 or none); VTK's " +
      "NRRD reader takes it for the components of a 2D image" + rewrite);
  }
  if (!dataFile.empty() && !IsReadableFile(DataFileBeside(path, dataFile)))
  {
    throw Failure(context + ": the NRRD header's data file '" + DataFileBeside(path, dataFile) +
      "' cannot be read");
  }
  if ((encoding == "ascii" || encoding == "text" || encoding == "txt") && dataFile.empty() &&
    !fileList && !filePattern)
  {
    double values = 1.0;
    for (const long long size : sizes)
    {
      values *= static_cast<double>(size);
    }
    long long numbers = 0;
    std::string token;
    while (numbers < values && file >> token)
    {
      double ignored = 0.0;
      if (!ParseNumber(token, ignored))
      {
        throw Failure(context + ": the NRRD file's ASCII data holds '" + token.substr(0, 20) +
          "', not a number, after " + std::to_string(numbers) + " values");
      }
      ++numbers;
    }
    if (numbers < values)
    {
      std::ostringstream message;
      message << context << ": the NRRD file's ASCII data holds " << numbers << " values for "
              << std::fixed << std::setprecision(0) << values << " voxels (truncated file?)";
      throw Failure(message.str());
    }
  }
}

} // namespace stmesh
