// SPDX-License-Identifier: BSD-3-Clause
/**
 * stmesh: the command-line front end of SpacetreeMesh.
 *
 * Reads a segmented (label) image, runs stmImageToSpacetree, stmSpacetreeBalance and
 * stmSpacetreeTessellate, and writes the result as a .vtu or legacy .vtk file, printing a
 * per-stage table of wall time, output size and peak memory. Run `stmesh --help` for the usage.
 *
 * Error policy: every failure (bad command line, unreadable or corrupt input, filter error,
 * write error) ends with messages on stderr that start with "stmesh: error:" and exit code 2 for
 * a usage error, 1 for anything else. VTK reports errors through vtkErrorMacro, which does not
 * throw, so every reader, filter, writer and executive gets an ErrorEvent observer, and the
 * output window (which receives the errors of objects without observers) is replaced; any
 * recorded error fails the run. The output is written to a temporary file that is renamed only
 * on success, so a failure never leaves a partial file under the requested name.
 */

#include "stmImageToSpacetree.h"
#include "stmSpacetreeBalance.h"
#include "stmSpacetreeTessellate.h"

#include "vtkAlgorithm.h"
#include "vtkCallbackCommand.h"
#include "vtkCellData.h"
#include "vtkCommand.h"
#include "vtkDataArray.h"
#include "vtkExecutive.h"
#include "vtkImageData.h"
#include "vtkLogger.h"
#include "vtkMetaImageReader.h"
#include "vtkNIFTIImageReader.h"
#include "vtkNew.h"
#include "vtkNrrdReader.h"
#include "vtkObjectFactory.h"
#include "vtkOutputWindow.h"
#include "vtkPointData.h"
#include "vtkSMPTools.h"
#include "vtkSmartPointer.h"
#include "vtkType.h"
#include "vtkUnstructuredGrid.h"
#include "vtkUnstructuredGridWriter.h"
#include "vtkVersion.h"
#include "vtkXMLImageDataReader.h"
#include "vtkXMLUnstructuredGridWriter.h"

#include <sys/resource.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <map>
#include <mutex>
#include <set>
#include <sstream>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <vector>

#ifndef STMESH_VERSION
#define STMESH_VERSION "unknown"
#endif

namespace
{
// Debian package mricron-data: the AAL atlas, a 181 x 217 x 181 label image with 116 regions.
const char* const DefaultInput = "/usr/share/mricron/templates/aal.nii.gz";

const int DefaultMaxCellSize = 16;
const int MaxMaxCellSize = 1 << 20; // stmImageToSpacetree clamps to this
const int DefaultBalanceLevel = 1;
const int MaxBalanceLevel = 20; // stmSpacetreeBalance clamps to this
const int MaxThreads = 4096;

const char* const UsageText =
  R"(Usage: stmesh [INPUT] [-o OUTPUT] [--labels 1,2,5] [--max-cell-size N] [--balance L]
              [--stop-after spacetree|balance|tessellate] [--threads N] [--summary FILE.json]
              [--compressor lz4|zlib|none]
       stmesh -h|--help
       stmesh --version

Mesh a segmented (label) image with SpacetreeMesh: build the spacetree of the labels, balance
it, and tessellate it into a conforming tetrahedral mesh with a cell array "Material".

Arguments:
  INPUT                 label image: .nii, .nii.gz (NIfTI), .mha, .mhd (MetaImage), .nrrd, .nhdr
                        (NRRD) or .vti (VTK XML image); integer scalars. Default:
                        /usr/share/mricron/templates/aal.nii.gz (Debian package mricron-data).
  -o OUTPUT             .vtu (VTK XML, inline binary) or .vtk (legacy VTK, binary). Default:
                        the input's base name with .vtu, in the current directory.
  --labels L1,L2,...    labels that form the body of interest. Default: every non-zero label.
  --max-cell-size N     largest leaf edge in voxels, 1 to 1048576. Default 16.
  --balance L           largest level difference between adjacent leaves, 1 to 20; 0 skips
                        balancing. Default 1 (best-shaped tetrahedra).
  --stop-after STAGE    write the output of spacetree, balance or tessellate (the default).
  --threads N           number of threads, 1 to 4096. Default: all cores, or VTK_SMP_MAX_THREADS.
                        The STDThread backend is used unless VTK_SMP_BACKEND_IN_USE is set.
  --summary FILE.json   also write the per-stage figures and per-material counts as JSON.
  --compressor C        compression of .vtu files: lz4 (the default, fastest), zlib (files
                        about 2.3 times smaller, written about 1 s slower per 5 million
                        tetrahedra) or none.
  -h, --help            show this help and exit.
  --version             show the version and exit.

Exit status: 0 on success, 1 on an error, 2 on a usage error.
)";

//------------------------------------------------------------------------------------------------
// Failures. Each line of what() becomes one "stmesh: error:" line on stderr.

class UsageError : public std::runtime_error
{
public:
  explicit UsageError(const std::string& message)
    : std::runtime_error(message)
  {
  }
};

class Failure : public std::runtime_error
{
public:
  explicit Failure(const std::string& message)
    : std::runtime_error(message)
  {
  }
};

//------------------------------------------------------------------------------------------------
// Small string helpers.

std::string ToLower(std::string text)
{
  std::transform(text.begin(), text.end(), text.begin(),
    [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return text;
}

bool EndsWith(const std::string& text, const std::string& suffix)
{
  return text.size() >= suffix.size() &&
    text.compare(text.size() - suffix.size(), suffix.size(), suffix) == 0;
}

std::string Trim(const std::string& text)
{
  const auto isSpace = [](unsigned char c) { return std::isspace(c) != 0; };
  auto begin = std::find_if_not(text.begin(), text.end(), isSpace);
  auto end = std::find_if_not(text.rbegin(), text.rend(), isSpace).base();
  return begin < end ? std::string(begin, end) : std::string();
}

std::string FileName(const std::string& path)
{
  const std::size_t slash = path.find_last_of('/');
  return slash == std::string::npos ? path : path.substr(slash + 1);
}

std::string DirectoryName(const std::string& path)
{
  const std::size_t slash = path.find_last_of('/');
  if (slash == std::string::npos)
  {
    return ".";
  }
  return slash == 0 ? "/" : path.substr(0, slash);
}

std::string AbsolutePath(const std::string& path)
{
  if (!path.empty() && path[0] == '/')
  {
    return path;
  }
  std::vector<char> buffer(4096);
  if (!getcwd(buffer.data(), buffer.size()))
  {
    return path;
  }
  return std::string(buffer.data()) + "/" + path;
}

//------------------------------------------------------------------------------------------------
// Input and output formats, chosen by extension (case-insensitive).

enum class ImageFormat
{
  NIfTI,
  MetaImage,
  NRRD,
  VTKImage
};

struct ImageFormatInfo
{
  const char* Extension;
  ImageFormat Format;
};

// Longest extensions first, so that ".nii.gz" wins over any shorter match.
const ImageFormatInfo ImageExtensions[] = { { ".nii.gz", ImageFormat::NIfTI },
  { ".nii", ImageFormat::NIfTI }, { ".mha", ImageFormat::MetaImage },
  { ".mhd", ImageFormat::MetaImage }, { ".nrrd", ImageFormat::NRRD },
  { ".nhdr", ImageFormat::NRRD }, { ".vti", ImageFormat::VTKImage } };

const char* const SupportedInputExtensions = ".nii, .nii.gz, .mha, .mhd, .nrrd, .nhdr, .vti";

const ImageFormatInfo* FindImageFormat(const std::string& path)
{
  const std::string lower = ToLower(FileName(path));
  for (const ImageFormatInfo& info : ImageExtensions)
  {
    if (EndsWith(lower, info.Extension) && lower.size() > std::strlen(info.Extension))
    {
      return &info;
    }
  }
  return nullptr;
}

const char* ImageFormatName(ImageFormat format)
{
  switch (format)
  {
    case ImageFormat::NIfTI:
      return "NIfTI";
    case ImageFormat::MetaImage:
      return "MetaImage";
    case ImageFormat::NRRD:
      return "NRRD";
    case ImageFormat::VTKImage:
      return "VTK XML image";
  }
  return "?";
}

enum class MeshFormat
{
  XMLUnstructuredGrid,
  LegacyVTK
};

bool FindMeshFormat(const std::string& path, MeshFormat& format)
{
  const std::string lower = ToLower(FileName(path));
  if (lower.size() > 4 && EndsWith(lower, ".vtu"))
  {
    format = MeshFormat::XMLUnstructuredGrid;
    return true;
  }
  if (lower.size() > 4 && EndsWith(lower, ".vtk"))
  {
    format = MeshFormat::LegacyVTK;
    return true;
  }
  return false;
}

//------------------------------------------------------------------------------------------------
// Command line.

enum class StopStage
{
  Spacetree,
  Balance,
  Tessellate
};

const char* StopStageName(StopStage stage)
{
  switch (stage)
  {
    case StopStage::Spacetree:
      return "spacetree";
    case StopStage::Balance:
      return "balance";
    case StopStage::Tessellate:
      return "tessellate";
  }
  return "?";
}

struct Options
{
  bool ShowHelp = false;
  bool ShowVersion = false;
  std::string Input;       // empty: the default image
  std::string Output;      // empty: derived from the input's name
  std::vector<int> Labels; // empty: every non-zero label
  int MaxCellSize = DefaultMaxCellSize;
  int BalanceLevel = DefaultBalanceLevel; // 0: no balancing
  StopStage StopAfter = StopStage::Tessellate;
  int Threads = 0; // 0: not given on the command line
  std::string SummaryPath;
  std::string Compressor = "lz4"; // of .vtu files: lz4, zlib or none
};

// strtoll skips leading blanks and stops at the first non-digit, so "3x", " 3" or "" would slip
// through; demand that the whole text is one decimal integer.
long long ParseInteger(
  const std::string& text, const std::string& what, long long minimum, long long maximum)
{
  if (text.empty())
  {
    throw UsageError(what + " needs an integer value, got an empty string");
  }
  if (std::isspace(static_cast<unsigned char>(text[0])))
  {
    throw UsageError(what + ": '" + text + "' is not an integer");
  }
  errno = 0;
  char* end = nullptr;
  const long long value = std::strtoll(text.c_str(), &end, 10);
  if (end == text.c_str() || *end != '\0')
  {
    throw UsageError(what + ": '" + text + "' is not an integer");
  }
  if (errno == ERANGE || value < minimum || value > maximum)
  {
    throw UsageError(what + ": " + text + " is out of range (" + std::to_string(minimum) + " to " +
      std::to_string(maximum) + ")");
  }
  return value;
}

std::vector<int> ParseLabels(const std::string& text)
{
  std::vector<int> labels;
  std::set<int> seen;
  std::size_t begin = 0;
  while (true)
  {
    const std::size_t comma = text.find(',', begin);
    const std::string item =
      Trim(text.substr(begin, comma == std::string::npos ? std::string::npos : comma - begin));
    if (item.empty())
    {
      throw UsageError(
        "--labels: empty entry in '" + text + "'; give comma-separated integers such as 1,2,5");
    }
    const int label = static_cast<int>(ParseInteger(item, "--labels", VTK_INT_MIN, VTK_INT_MAX));
    if (label == 0)
    {
      throw UsageError("--labels: 0 is the background label and cannot be part of the body");
    }
    if (!seen.insert(label).second)
    {
      throw UsageError("--labels: label " + item + " is listed twice");
    }
    labels.push_back(label);
    if (comma == std::string::npos)
    {
      break;
    }
    begin = comma + 1;
  }
  return labels;
}

Options ParseCommandLine(int argc, char* argv[])
{
  Options options;
  bool inputGiven = false;
  bool optionsEnded = false;
  std::set<std::string> seenOptions;
  for (int i = 1; i < argc; ++i)
  {
    const std::string argument = argv[i];
    if (!optionsEnded && argument == "--")
    {
      optionsEnded = true;
      continue;
    }
    if (optionsEnded || argument.size() < 2 || argument[0] != '-')
    {
      if (inputGiven)
      {
        throw UsageError("more than one INPUT given ('" + options.Input + "' and '" + argument +
          "'); stmesh meshes one image per run");
      }
      if (argument.empty())
      {
        throw UsageError("INPUT is an empty string");
      }
      options.Input = argument;
      inputGiven = true;
      continue;
    }
    if (argument == "-h" || argument == "--help")
    {
      options.ShowHelp = true;
      continue;
    }
    if (argument == "--version")
    {
      options.ShowVersion = true;
      continue;
    }

    // Options with a value: "--name value" or "--name=value" ("-o value" only).
    std::string name = argument;
    std::string value;
    bool inlineValue = false;
    const std::size_t equals = argument.find('=');
    if (argument.compare(0, 2, "--") == 0 && equals != std::string::npos)
    {
      name = argument.substr(0, equals);
      value = argument.substr(equals + 1);
      inlineValue = true;
    }
    static const std::set<std::string> valueOptions = { "-o", "--labels", "--max-cell-size",
      "--balance", "--stop-after", "--threads", "--summary", "--compressor" };
    if (valueOptions.count(name) == 0)
    {
      throw UsageError("unknown option '" + name + "'");
    }
    if (!inlineValue)
    {
      if (i + 1 >= argc)
      {
        throw UsageError(name + " needs a value");
      }
      value = argv[++i];
    }
    if (!seenOptions.insert(name).second)
    {
      throw UsageError(name + " given more than once");
    }

    if (name == "-o")
    {
      if (value.empty())
      {
        throw UsageError("-o needs a file name");
      }
      options.Output = value;
    }
    else if (name == "--labels")
    {
      options.Labels = ParseLabels(value);
    }
    else if (name == "--max-cell-size")
    {
      options.MaxCellSize = static_cast<int>(ParseInteger(value, name, 1, MaxMaxCellSize));
    }
    else if (name == "--balance")
    {
      options.BalanceLevel = static_cast<int>(ParseInteger(value, name, 0, MaxBalanceLevel));
    }
    else if (name == "--stop-after")
    {
      if (value == "spacetree")
      {
        options.StopAfter = StopStage::Spacetree;
      }
      else if (value == "balance")
      {
        options.StopAfter = StopStage::Balance;
      }
      else if (value == "tessellate")
      {
        options.StopAfter = StopStage::Tessellate;
      }
      else
      {
        throw UsageError(
          "--stop-after: '" + value + "' is not one of spacetree, balance, tessellate");
      }
    }
    else if (name == "--compressor")
    {
      if (value != "lz4" && value != "zlib" && value != "none")
      {
        throw UsageError("--compressor: '" + value + "' is not one of lz4, zlib, none");
      }
      options.Compressor = value;
    }
    else if (name == "--threads")
    {
      options.Threads = static_cast<int>(ParseInteger(value, name, 1, MaxThreads));
    }
    else if (name == "--summary")
    {
      if (value.empty())
      {
        throw UsageError("--summary needs a file name");
      }
      options.SummaryPath = value;
    }
  }

  MeshFormat format;
  if (!options.Output.empty() && !FindMeshFormat(options.Output, format))
  {
    throw UsageError("output '" + options.Output +
      "' has an unsupported extension; use .vtu (VTK XML) or .vtk (legacy VTK)");
  }
  return options;
}

//------------------------------------------------------------------------------------------------
// VTK error capture.

// VTK messages look like "ERROR: In file.cxx, line 12\nvtkClass (0x55d0c0): text\n\n"; keep
// "vtkClass: text", which is what a user can act on.
std::string CleanVTKMessage(const std::string& message)
{
  std::string text = message;
  if (text.compare(0, 10, "ERROR: In ") == 0 || text.compare(0, 12, "Warning: In ") == 0 ||
    text.compare(0, 20, "Generic Warning: In ") == 0)
  {
    const std::size_t newline = text.find('\n');
    text = newline == std::string::npos ? std::string() : text.substr(newline + 1);
  }
  // Drop the object addresses " (0x55d0c0)": noise to a user, and different on every run.
  std::size_t address = 0;
  while ((address = text.find(" (0x", address)) != std::string::npos)
  {
    std::size_t end = address + 4;
    while (end < text.size() && std::isxdigit(static_cast<unsigned char>(text[end])))
    {
      ++end;
    }
    if (end < text.size() && text[end] == ')' && end > address + 4)
    {
      text.erase(address, end + 1 - address);
    }
    else
    {
      address = end;
    }
  }
  return Trim(text);
}

/// stderr as it was at start-up. While a reader runs, std::cerr is captured (see
/// StandardErrorCapture), so stmesh's own warnings go through this stream instead.
std::ostream& Diagnostics()
{
  static std::ostream stream(std::cerr.rdbuf());
  return stream;
}

// All VTK errors of the run, in order. The executives' "Algorithm X returned failure for request"
// only repeats that a filter failed, so it is kept apart and shown only when nothing more
// specific was reported.
class ErrorLog
{
public:
  void Record(const std::string& message, bool fromExecutive)
  {
    std::lock_guard<std::mutex> lock(this->Mutex);
    std::string text = CleanVTKMessage(message);
    if (fromExecutive)
    {
      // The rest of the message dumps the whole pipeline request.
      const std::size_t colon = text.find(" for request:");
      if (colon != std::string::npos)
      {
        text = text.substr(0, colon);
      }
      this->ExecutiveMessages.push_back(text);
    }
    else
    {
      this->Messages.push_back(text.empty() ? std::string("unspecified VTK error") : text);
    }
  }

  bool HasErrors()
  {
    std::lock_guard<std::mutex> lock(this->Mutex);
    return !this->Messages.empty() || !this->ExecutiveMessages.empty();
  }

  /// The recorded messages, one per line, and a clean log for the next stage.
  std::string Take()
  {
    std::lock_guard<std::mutex> lock(this->Mutex);
    const std::vector<std::string>& chosen =
      this->Messages.empty() ? this->ExecutiveMessages : this->Messages;
    std::string joined;
    for (const std::string& message : chosen)
    {
      joined += (joined.empty() ? "" : "\n") + message;
    }
    this->Messages.clear();
    this->ExecutiveMessages.clear();
    return joined;
  }

private:
  std::mutex Mutex;
  std::vector<std::string> Messages;
  std::vector<std::string> ExecutiveMessages;
};

ErrorLog& Errors()
{
  static ErrorLog log;
  return log;
}

// vtkImageReader (the base of vtkNrrdReader) only warns when a file is shorter than its header
// promises, and then returns partly uninitialised voxels: such a warning must fail the run.
void HandleWarning(const char* message)
{
  const std::string text = CleanVTKMessage(message ? message : "");
  if (text.find("File operation failed") != std::string::npos)
  {
    Errors().Record(text + " (the file is truncated or corrupt)", false);
    return;
  }
  Diagnostics() << "stmesh: warning: " << text << '\n';
}

// Receives the errors and warnings of objects that have no ErrorEvent observer (internal helpers
// of the readers, for instance): errors go to the log, warnings to stderr, and nothing ever goes
// to a popup or to stdout, which carries the table.
class stmeshOutputWindow : public vtkOutputWindow
{
public:
  static stmeshOutputWindow* New();
  vtkTypeMacro(stmeshOutputWindow, vtkOutputWindow);

  void DisplayErrorText(const char* text) override { Errors().Record(text ? text : "", false); }
  void DisplayWarningText(const char* text) override { this->Warn(text); }
  void DisplayGenericWarningText(const char* text) override { this->Warn(text); }
  void DisplayDebugText(const char*) override {}
  void DisplayText(const char* text) override
  {
    if (text)
    {
      Diagnostics() << "stmesh: " << Trim(text) << '\n';
    }
  }

protected:
  stmeshOutputWindow() = default;
  ~stmeshOutputWindow() override = default;

private:
  void Warn(const char* text) { HandleWarning(text); }

  stmeshOutputWindow(const stmeshOutputWindow&) = delete;
  void operator=(const stmeshOutputWindow&) = delete;
};
vtkStandardNewMacro(stmeshOutputWindow);

void RecordAlgorithmError(vtkObject*, unsigned long, void*, void* callData)
{
  Errors().Record(callData ? static_cast<const char*>(callData) : "", false);
}

void RecordExecutiveError(vtkObject*, unsigned long, void*, void* callData)
{
  Errors().Record(callData ? static_cast<const char*>(callData) : "", true);
}

void RecordWarning(vtkObject*, unsigned long, void*, void* callData)
{
  HandleWarning(static_cast<const char*>(callData));
}

/// MetaIO (inside vtkMetaImageReader) reports problems such as "data not read completely" on
/// std::cerr instead of through VTK, and the reader still succeeds. Everything written to
/// std::cerr while an instance lives is kept, to be treated as an error.
class StandardErrorCapture
{
public:
  StandardErrorCapture()
    : Saved(std::cerr.rdbuf(this->Captured.rdbuf()))
  {
  }
  ~StandardErrorCapture() { std::cerr.rdbuf(this->Saved); }

  std::string GetText() const { return Trim(this->Captured.str()); }

private:
  std::ostringstream Captured;
  std::streambuf* Saved;

  StandardErrorCapture(const StandardErrorCapture&) = delete;
  void operator=(const StandardErrorCapture&) = delete;
};

/// Observe the errors (and warnings) of an algorithm and of its executive.
void Watch(vtkAlgorithm* algorithm)
{
  vtkNew<vtkCallbackCommand> onError;
  onError->SetCallback(RecordAlgorithmError);
  algorithm->AddObserver(vtkCommand::ErrorEvent, onError);
  vtkNew<vtkCallbackCommand> onWarning;
  onWarning->SetCallback(RecordWarning);
  algorithm->AddObserver(vtkCommand::WarningEvent, onWarning);
  vtkNew<vtkCallbackCommand> onExecutiveError;
  onExecutiveError->SetCallback(RecordExecutiveError);
  algorithm->GetExecutive()->AddObserver(vtkCommand::ErrorEvent, onExecutiveError);
}

/// Throw the recorded errors, if any, with the context ("reading 'x.nii'") on every line.
void ThrowIfFailed(const std::string& context)
{
  if (!Errors().HasErrors())
  {
    return;
  }
  std::istringstream lines(Errors().Take());
  std::string message;
  std::string line;
  while (std::getline(lines, line))
  {
    if (!Trim(line).empty())
    {
      message += (message.empty() ? "" : "\n") + context + ": " + Trim(line);
    }
  }
  throw Failure(message.empty() ? context + " failed" : message);
}

//------------------------------------------------------------------------------------------------
// Temporary output files: written next to the target and renamed on success. A signal handler
// removes the file being written, so that Ctrl-C does not leave a stray temporary behind.

char PendingTemporaryPath[4096] = { 0 };

extern "C" void RemovePendingTemporaryAndExit(int signalNumber)
{
  if (PendingTemporaryPath[0] != '\0')
  {
    unlink(PendingTemporaryPath); // async-signal-safe
  }
  std::signal(signalNumber, SIG_DFL);
  std::raise(signalNumber);
}

class TemporaryFile
{
public:
  explicit TemporaryFile(const std::string& target)
    : Target(target)
    , Path(target + ".tmp-" + std::to_string(static_cast<long>(getpid())))
  {
    if (this->Path.size() < sizeof(PendingTemporaryPath))
    {
      std::strcpy(PendingTemporaryPath, this->Path.c_str());
    }
  }

  ~TemporaryFile()
  {
    PendingTemporaryPath[0] = '\0';
    if (!this->Committed)
    {
      std::remove(this->Path.c_str());
    }
  }

  const std::string& GetPath() const { return this->Path; }

  void Commit()
  {
    if (std::rename(this->Path.c_str(), this->Target.c_str()) != 0)
    {
      throw Failure(
        "cannot rename '" + this->Path + "' to '" + this->Target + "': " + std::strerror(errno));
    }
    this->Committed = true;
  }

private:
  std::string Target;
  std::string Path;
  bool Committed = false;

  TemporaryFile(const TemporaryFile&) = delete;
  void operator=(const TemporaryFile&) = delete;
};

/// Fail early, before minutes of meshing, if a result could not be written.
void CheckWritableTarget(const std::string& path, const std::string& what)
{
  struct stat info;
  if (stat(path.c_str(), &info) == 0 && S_ISDIR(info.st_mode))
  {
    throw Failure(what + " '" + path + "' is a directory");
  }
  const std::string directory = DirectoryName(path);
  if (stat(directory.c_str(), &info) != 0 || !S_ISDIR(info.st_mode))
  {
    throw Failure(what + " '" + path + "': directory '" + directory + "' does not exist");
  }
  if (access(directory.c_str(), W_OK | X_OK) != 0)
  {
    throw Failure(what + " '" + path + "': directory '" + directory + "' is not writable");
  }
}

//------------------------------------------------------------------------------------------------
// Stage bookkeeping.

struct StageReport
{
  std::string Name;
  bool Skipped = false;
  double Seconds = 0.0;
  long long Leaves = -1; // -1: not applicable
  long long Cells = -1;
  long long Points = -1;
  long long FileBytes = -1;
  double PeakRssMiB = 0.0;
  std::string Description; // the table's "output" column
};

double PeakRssMiB()
{
  struct rusage usage;
  if (getrusage(RUSAGE_SELF, &usage) != 0)
  {
    return 0.0;
  }
  return static_cast<double>(usage.ru_maxrss) / 1024.0; // Linux reports KiB
}

using Clock = std::chrono::steady_clock;

double SecondsSince(Clock::time_point start)
{
  return std::chrono::duration<double>(Clock::now() - start).count();
}

double TimedUpdate(vtkAlgorithm* algorithm)
{
  const Clock::time_point start = Clock::now();
  algorithm->Update();
  return SecondsSince(start);
}

//------------------------------------------------------------------------------------------------
// Threads.

struct ThreadSetup
{
  std::string Backend;
  int Threads = 1;
};

ThreadSetup SetUpThreads(int requestedThreads)
{
  // Debian's VTK defaults to the Sequential backend; STDThread is compiled in and gives threads
  // without the user doing anything. A backend chosen through the environment wins.
  const char* backendFromEnvironment = std::getenv("VTK_SMP_BACKEND_IN_USE");
  if (!backendFromEnvironment || !*backendFromEnvironment)
  {
    if (!vtkSMPTools::SetBackend("STDThread"))
    {
      Diagnostics() << "stmesh: warning: VTK's STDThread backend is not available; running with "
                       "the "
                    << vtkSMPTools::GetBackend() << " backend\n";
    }
  }

  int threads = requestedThreads;
  const char* maxThreadsFromEnvironment = std::getenv("VTK_SMP_MAX_THREADS");
  if (threads == 0 && maxThreadsFromEnvironment && *maxThreadsFromEnvironment)
  {
    try
    {
      threads = static_cast<int>(
        ParseInteger(maxThreadsFromEnvironment, "VTK_SMP_MAX_THREADS", 1, MaxThreads));
    }
    catch (const UsageError& error)
    {
      // Not a command-line mistake, but still a configuration the user must fix.
      throw Failure(std::string("environment variable ") + error.what());
    }
  }
  vtkSMPTools::Initialize(threads); // 0: every core
  ThreadSetup setup;
  setup.Backend = vtkSMPTools::GetBackend() ? vtkSMPTools::GetBackend() : "unknown";
  setup.Threads = vtkSMPTools::GetEstimatedNumberOfThreads();
  return setup;
}

//------------------------------------------------------------------------------------------------
// Reading.

struct ImageInfo
{
  int Dimensions[3] = { 0, 0, 0 };
  double Spacing[3] = { 0.0, 0.0, 0.0 };
  std::string ScalarType;
  std::string Format;
};

void CheckReadableFile(const std::string& path)
{
  struct stat info;
  if (stat(path.c_str(), &info) != 0)
  {
    throw Failure("cannot read input '" + path + "': " + std::strerror(errno));
  }
  if (S_ISDIR(info.st_mode))
  {
    throw Failure("input '" + path + "' is a directory, not an image file");
  }
  if (access(path.c_str(), R_OK) != 0)
  {
    throw Failure("cannot read input '" + path + "': " + std::strerror(errno));
  }
  if (info.st_size == 0)
  {
    throw Failure("input '" + path + "' is empty");
  }
}

/// A MetaImage header is text: "Key = Value" lines, with NDims among them and ElementDataFile
/// last, before the voxels (.mha) or alone (.mhd).
bool LooksLikeMetaImageHeader(const std::string& path)
{
  std::ifstream file(path, std::ios::binary);
  std::string header(8192, '\0');
  file.read(&header[0], static_cast<std::streamsize>(header.size()));
  header.resize(static_cast<std::size_t>(file.gcount()));
  const std::size_t dataFile = header.find("ElementDataFile");
  const std::size_t dimensions = header.find("NDims");
  return dataFile != std::string::npos && dimensions != std::string::npos &&
    dimensions < dataFile && header.find('\0') > dataFile;
}

template <class Reader>
vtkSmartPointer<vtkAlgorithm> CreateCheckedReader(
  const std::string& path, const char* formatName, const std::string& context)
{
  vtkSmartPointer<Reader> reader = vtkSmartPointer<Reader>::New();
  Watch(reader);
  // vtkMetaImageReader::CanReadFile wants a lower-case .mha or .mhd, which stmesh does not.
  const bool canRead = (std::is_same<Reader, vtkMetaImageReader>::value &&
                         !EndsWith(path, ".mha") && !EndsWith(path, ".mhd"))
    ? LooksLikeMetaImageHeader(path)
    : reader->CanReadFile(path.c_str()) != 0;
  if (!canRead)
  {
    std::string details = Errors().HasErrors() ? "\n" + Errors().Take() : std::string();
    throw Failure(context + ": not a valid " + formatName + " file (" + reader->GetClassName() +
      " cannot read it)" + details);
  }
  ThrowIfFailed(context);
  reader->SetFileName(path.c_str());
  return reader;
}

/// Read the label image; the returned copy no longer depends on the reader.
vtkSmartPointer<vtkImageData> ReadImage(
  const std::string& path, ImageInfo& info, StageReport& report)
{
  const std::string context = "reading '" + path + "'";
  const ImageFormatInfo* format = FindImageFormat(path);
  if (!format)
  {
    throw Failure("input '" + path + "' has an unsupported extension; stmesh reads " +
      SupportedInputExtensions);
  }
  CheckReadableFile(path);

  vtkSmartPointer<vtkAlgorithm> reader;
  StandardErrorCapture strayMessages;
  switch (format->Format)
  {
    case ImageFormat::NIfTI:
      reader = CreateCheckedReader<vtkNIFTIImageReader>(path, "NIfTI", context);
      break;
    case ImageFormat::MetaImage:
      reader = CreateCheckedReader<vtkMetaImageReader>(path, "MetaImage", context);
      break;
    case ImageFormat::NRRD:
      reader = CreateCheckedReader<vtkNrrdReader>(path, "NRRD", context);
      break;
    case ImageFormat::VTKImage:
      reader = CreateCheckedReader<vtkXMLImageDataReader>(path, "VTK XML image", context);
      break;
  }
  info.Format = ImageFormatName(format->Format);

  report.Seconds = TimedUpdate(reader);
  const std::string strayText = strayMessages.GetText();
  if (!strayText.empty())
  {
    Errors().Record(strayText, false);
  }
  ThrowIfFailed(context);

  vtkImageData* image = vtkImageData::SafeDownCast(reader->GetOutputDataObject(0));
  if (!image || image->GetNumberOfPoints() == 0)
  {
    throw Failure(context + ": the file holds no image data");
  }
  image->GetDimensions(info.Dimensions);
  image->GetSpacing(info.Spacing);
  // The spacetree filter reads the active scalars, point data first.
  vtkDataArray* labels = image->GetPointData()->GetScalars();
  vtkIdType expectedValues = image->GetNumberOfPoints();
  if (!labels)
  {
    labels = image->GetCellData()->GetScalars();
    expectedValues = image->GetNumberOfCells();
  }
  if (!labels)
  {
    throw Failure(context + ": the image has no scalar (label) array");
  }
  if (labels->GetNumberOfTuples() != expectedValues)
  {
    throw Failure(context + ": the image has " + std::to_string(expectedValues) + " voxels but " +
      std::to_string(labels->GetNumberOfTuples()) + " values (truncated file?)");
  }
  info.ScalarType = labels->GetDataTypeAsString();
  if (labels->GetNumberOfComponents() != 1)
  {
    throw Failure(context + ": the image has " + std::to_string(labels->GetNumberOfComponents()) +
      " components per voxel; stmesh needs one integer label per voxel");
  }
  if (!stmImageToSpacetree::IsLabelType(labels->GetDataType()))
  {
    throw Failure(context + ": the image holds " + info.ScalarType +
      " values; stmesh needs an integer label image (a segmentation, not a gray-value image)");
  }
  if (auto* nifti = vtkNIFTIImageReader::SafeDownCast(reader))
  {
    const double slope = nifti->GetRescaleSlope();
    const double intercept = nifti->GetRescaleIntercept();
    if ((slope != 0.0 && slope != 1.0) || intercept != 0.0)
    {
      Diagnostics() << "stmesh: warning: " << path << ": scl_slope " << slope << " and scl_inter "
                    << intercept << " are ignored; the labels are the stored values\n";
    }
  }

  vtkSmartPointer<vtkImageData> copy = vtkSmartPointer<vtkImageData>::New();
  copy->ShallowCopy(image);
  report.Points = static_cast<long long>(image->GetNumberOfPoints());
  report.PeakRssMiB = PeakRssMiB();
  std::ostringstream description;
  description << info.Dimensions[0] << " x " << info.Dimensions[1] << " x " << info.Dimensions[2]
              << " voxels, " << info.ScalarType;
  report.Description = description.str();
  return copy;
}

//------------------------------------------------------------------------------------------------
// Meshing stages: each filter runs on a detached copy of the previous result, so that the
// previous filter (and, once unreferenced, its data) can be freed; this keeps the peak memory
// near two stages' worth instead of all of them.

vtkSmartPointer<vtkUnstructuredGrid> RunStage(vtkAlgorithm* filter, vtkDataObject* input,
  const std::string& context, StageReport& report, bool isSpacetree)
{
  Watch(filter);
  filter->SetInputDataObject(0, input);
  report.Seconds = TimedUpdate(filter);
  ThrowIfFailed(context);
  vtkUnstructuredGrid* output = vtkUnstructuredGrid::SafeDownCast(filter->GetOutputDataObject(0));
  if (!output)
  {
    throw Failure(context + ": the filter produced no output");
  }
  vtkSmartPointer<vtkUnstructuredGrid> copy = vtkSmartPointer<vtkUnstructuredGrid>::New();
  copy->ShallowCopy(output);
  filter->SetInputDataObject(0, nullptr);
  report.Cells = static_cast<long long>(copy->GetNumberOfCells());
  report.Points = static_cast<long long>(copy->GetNumberOfPoints());
  std::ostringstream description;
  if (isSpacetree)
  {
    report.Leaves = report.Cells;
    description << report.Leaves << " leaves";
  }
  else
  {
    description << report.Cells << " cells, " << report.Points << " points";
  }
  report.Description = description.str();
  report.PeakRssMiB = PeakRssMiB();
  return copy;
}

//------------------------------------------------------------------------------------------------
// Writing.

long long FileSize(const std::string& path)
{
  struct stat info;
  return stat(path.c_str(), &info) == 0 ? static_cast<long long>(info.st_size) : -1;
}

void WriteMesh(vtkUnstructuredGrid* grid, const std::string& path, MeshFormat format,
  const std::string& compressor, StageReport& report)
{
  const std::string context = "writing '" + path + "'";
  TemporaryFile temporary(path);
  const Clock::time_point start = Clock::now();
  int written = 0;
  unsigned long errorCode = 0;
  if (format == MeshFormat::XMLUnstructuredGrid)
  {
    vtkNew<vtkXMLUnstructuredGridWriter> writer;
    Watch(writer);
    writer->SetInputData(grid);
    writer->SetFileName(temporary.GetPath().c_str());
    // Inline binary, never appended: Debian 12's libexpat fails on appended-mode files.
    writer->SetDataModeToBinary();
    // The writer compresses and base64-encodes on one thread, so the compressor sets the write
    // time: LZ4 is the fastest; zlib at level 1 (about twice as fast as its default level 5,
    // files ~2% larger) makes files about 2.3 times smaller than LZ4.
    if (compressor == "zlib")
    {
      writer->SetCompressorTypeToZLib();
      writer->SetCompressionLevel(1);
    }
    else if (compressor == "lz4")
    {
      writer->SetCompressorTypeToLZ4();
    }
    else
    {
      writer->SetCompressorTypeToNone();
    }
    // Each compressed block pays for a new compressor stream: 1 MiB blocks instead of the
    // default 32 KiB make the AAL mesh's write about a third faster for the same file size.
    writer->SetBlockSize(1 << 20);
    // 64-bit headers lift the 4 GiB limit on one array.
    writer->SetHeaderTypeToUInt64();
    written = writer->Write();
    errorCode = writer->GetErrorCode();
  }
  else
  {
    vtkNew<vtkUnstructuredGridWriter> writer;
    Watch(writer);
    writer->SetInputData(grid);
    writer->SetFileName(temporary.GetPath().c_str());
    writer->SetFileTypeToBinary();
    written = writer->Write();
    errorCode = writer->GetErrorCode();
  }
  ThrowIfFailed(context);
  if (!written || errorCode != 0)
  {
    throw Failure(context + ": the writer failed (disk full or I/O error?)");
  }
  report.FileBytes = FileSize(temporary.GetPath());
  if (report.FileBytes <= 0)
  {
    throw Failure(context + ": the written file is missing or empty");
  }
  temporary.Commit();
  report.Seconds = SecondsSince(start);
  report.PeakRssMiB = PeakRssMiB();
  std::ostringstream description;
  description << std::fixed << std::setprecision(1)
              << static_cast<double>(report.FileBytes) / (1024.0 * 1024.0) << " MiB "
              << FileName(path);
  report.Description = description.str();
}

//------------------------------------------------------------------------------------------------
// Material counts: cells per value of the "Material" cell array.

std::map<long long, long long> CountCellsPerMaterial(vtkUnstructuredGrid* grid)
{
  std::map<long long, long long> counts;
  vtkDataArray* materials = grid->GetCellData()->GetArray("Material");
  if (!materials)
  {
    return counts;
  }
  const vtkIdType count = materials->GetNumberOfTuples();
  for (vtkIdType cell = 0; cell < count; ++cell)
  {
    ++counts[static_cast<long long>(materials->GetTuple1(cell))];
  }
  return counts;
}

/// The JSON key of the per-material counts names what is counted.
std::string MaterialCountKey(vtkUnstructuredGrid* grid, StopStage stopAfter)
{
  if (stopAfter != StopStage::Tessellate)
  {
    return "leaves_per_material";
  }
  if (grid->GetNumberOfCells() > 0 && grid->GetCellType(0) == VTK_TRIANGLE)
  {
    return "triangles_per_material"; // a 2D image
  }
  return "tetrahedra_per_material";
}

//------------------------------------------------------------------------------------------------
// Report: the table on stdout and the JSON summary.

void PrintTable(const std::vector<StageReport>& stages, double totalSeconds)
{
  char line[256];
  std::snprintf(
    line, sizeof(line), "%-11s %9s  %-38s %12s\n", "stage", "seconds", "output", "peak RSS MiB");
  std::cout << line;
  for (const StageReport& stage : stages)
  {
    if (stage.Skipped)
    {
      std::snprintf(line, sizeof(line), "%-11s %9s  %-38s %12s\n", stage.Name.c_str(), "-",
        stage.Description.c_str(), "-");
    }
    else
    {
      std::snprintf(line, sizeof(line), "%-11s %9.3f  %-38s %12.1f\n", stage.Name.c_str(),
        stage.Seconds, stage.Description.c_str(), stage.PeakRssMiB);
    }
    std::cout << line;
  }
  std::snprintf(
    line, sizeof(line), "%-11s %9.3f  %-38s %12.1f\n", "total", totalSeconds, "", PeakRssMiB());
  std::cout << line;
  std::cout.flush();
}

std::string JsonString(const std::string& text)
{
  std::string quoted = "\"";
  for (const char c : text)
  {
    switch (c)
    {
      case '"':
        quoted += "\\\"";
        break;
      case '\\':
        quoted += "\\\\";
        break;
      case '\n':
        quoted += "\\n";
        break;
      case '\t':
        quoted += "\\t";
        break;
      default:
        if (static_cast<unsigned char>(c) < 0x20)
        {
          char escaped[8];
          std::snprintf(escaped, sizeof(escaped), "\\u%04x", static_cast<unsigned char>(c));
          quoted += escaped;
        }
        else
        {
          quoted += c;
        }
    }
  }
  return quoted + "\"";
}

std::string JsonCount(long long value)
{
  return value < 0 ? std::string("null") : std::to_string(value);
}

struct RunSummary
{
  std::string Input;
  std::string Output;
  bool DefaultInput = false;
  ImageInfo Image;
  ThreadSetup Threads;
  std::vector<StageReport> Stages;
  double TotalSeconds = 0.0;
  std::string MaterialKey;
  std::map<long long, long long> CellsPerMaterial;
};

void WriteSummary(const std::string& path, const Options& options, const RunSummary& summary)
{
  std::ostringstream json;
  json << std::fixed;
  json << "{\n";
  json << "  \"program\": \"stmesh\",\n";
  json << "  \"version\": " << JsonString(STMESH_VERSION) << ",\n";
  json << "  \"input\": " << JsonString(summary.Input) << ",\n";
  json << "  \"default_input\": " << (summary.DefaultInput ? "true" : "false") << ",\n";
  json << "  \"input_format\": " << JsonString(summary.Image.Format) << ",\n";
  json << "  \"output\": " << JsonString(summary.Output) << ",\n";
  json << "  \"image\": {\"dimensions\": [" << summary.Image.Dimensions[0] << ", "
       << summary.Image.Dimensions[1] << ", " << summary.Image.Dimensions[2] << "], \"spacing\": ["
       << std::setprecision(6) << summary.Image.Spacing[0] << ", " << summary.Image.Spacing[1]
       << ", " << summary.Image.Spacing[2]
       << "], \"scalar_type\": " << JsonString(summary.Image.ScalarType) << "},\n";
  json << "  \"parameters\": {\"labels\": [";
  for (std::size_t i = 0; i < options.Labels.size(); ++i)
  {
    json << (i ? ", " : "") << options.Labels[i];
  }
  json << "], \"all_labels\": " << (options.Labels.empty() ? "true" : "false")
       << ", \"max_cell_size\": " << options.MaxCellSize
       << ", \"balance\": " << options.BalanceLevel
       << ", \"stop_after\": " << JsonString(StopStageName(options.StopAfter))
       << ", \"compressor\": " << JsonString(options.Compressor) << "},\n";
  json << "  \"threads\": " << summary.Threads.Threads << ",\n";
  json << "  \"smp_backend\": " << JsonString(summary.Threads.Backend) << ",\n";
  json << "  \"stages\": [\n";
  for (std::size_t i = 0; i < summary.Stages.size(); ++i)
  {
    const StageReport& stage = summary.Stages[i];
    json << "    {\"name\": " << JsonString(stage.Name)
         << ", \"skipped\": " << (stage.Skipped ? "true" : "false")
         << ", \"seconds\": " << std::setprecision(6) << stage.Seconds
         << ", \"cells\": " << JsonCount(stage.Cells) << ", \"points\": " << JsonCount(stage.Points)
         << ", \"leaves\": " << JsonCount(stage.Leaves)
         << ", \"file_bytes\": " << JsonCount(stage.FileBytes)
         << ", \"peak_rss_mib\": " << std::setprecision(3) << stage.PeakRssMiB << "}"
         << (i + 1 < summary.Stages.size() ? "," : "") << "\n";
  }
  json << "  ],\n";
  json << "  \"total_seconds\": " << std::setprecision(6) << summary.TotalSeconds << ",\n";
  json << "  \"peak_rss_mib\": " << std::setprecision(3) << PeakRssMiB() << ",\n";
  json << "  " << JsonString(summary.MaterialKey) << ": {";
  bool first = true;
  for (const auto& entry : summary.CellsPerMaterial)
  {
    json << (first ? "" : ", ") << JsonString(std::to_string(entry.first)) << ": " << entry.second;
    first = false;
  }
  json << "}\n";
  json << "}\n";

  TemporaryFile temporary(path);
  {
    std::ofstream file(temporary.GetPath(), std::ios::out | std::ios::trunc);
    file << json.str();
    file.close();
    if (!file)
    {
      throw Failure("cannot write summary '" + path + "': " + std::strerror(errno));
    }
  }
  temporary.Commit();
}

//------------------------------------------------------------------------------------------------

/// The default output: the input's base name without its image extension, plus ".vtu", in the
/// current directory.
std::string DefaultOutputName(const std::string& input)
{
  std::string name = FileName(input);
  if (const ImageFormatInfo* format = FindImageFormat(input))
  {
    name.resize(name.size() - std::strlen(format->Extension));
  }
  return name + ".vtu";
}

int Run(const Options& options)
{
  RunSummary summary;
  std::string input = options.Input;
  if (input.empty())
  {
    input = DefaultInput;
    summary.DefaultInput = true;
    std::cout << "stmesh: no INPUT given; meshing the default image " << input << '\n';
    if (access(input.c_str(), F_OK) != 0)
    {
      throw Failure(std::string("the default image ") + input +
        " does not exist; install the Debian package mricron-data or give an INPUT");
    }
  }
  const std::string output = options.Output.empty() ? DefaultOutputName(input) : options.Output;
  MeshFormat meshFormat;
  if (!FindMeshFormat(output, meshFormat))
  {
    // Only reachable for a derived name; the command line was checked already.
    throw Failure("output '" + output + "' has an unsupported extension");
  }
  if (!FindImageFormat(input))
  {
    throw Failure("input '" + input + "' has an unsupported extension; stmesh reads " +
      SupportedInputExtensions);
  }
  CheckReadableFile(input);
  CheckWritableTarget(output, "output");
  if (!options.SummaryPath.empty())
  {
    CheckWritableTarget(options.SummaryPath, "summary");
  }
  summary.Input = AbsolutePath(input);
  summary.Output = AbsolutePath(output);
  if (!options.SummaryPath.empty() && AbsolutePath(options.SummaryPath) == summary.Output)
  {
    throw Failure("the summary and the output are the same file '" + output + "'");
  }
  summary.Threads = SetUpThreads(options.Threads);

  std::cout << "input:   " << input << '\n';
  std::cout << "output:  " << output << '\n';
  std::cout << "threads: " << summary.Threads.Threads << " (" << summary.Threads.Backend
            << " backend)\n";
  std::cout.flush();

  const Clock::time_point start = Clock::now();

  StageReport readReport;
  readReport.Name = "read";
  vtkSmartPointer<vtkImageData> image = ReadImage(input, summary.Image, readReport);
  summary.Stages.push_back(readReport);

  StageReport spacetreeReport;
  spacetreeReport.Name = "spacetree";
  vtkSmartPointer<vtkUnstructuredGrid> grid;
  {
    vtkNew<stmImageToSpacetree> spacetree;
    for (int label : options.Labels)
    {
      spacetree->AddBodyLabel(label);
    }
    spacetree->SetMaxCellSize(options.MaxCellSize);
    grid = RunStage(spacetree, image, "building the spacetree", spacetreeReport, true);
  }
  image = nullptr; // the image is no longer needed: free it before the next stages
  summary.Stages.push_back(spacetreeReport);

  if (options.StopAfter != StopStage::Spacetree)
  {
    StageReport balanceReport;
    balanceReport.Name = "balance";
    if (options.BalanceLevel == 0)
    {
      balanceReport.Skipped = true;
      balanceReport.Description = "skipped (--balance 0)";
    }
    else
    {
      vtkNew<stmSpacetreeBalance> balance;
      balance->SetBalanceLevel(options.BalanceLevel);
      grid = RunStage(balance, grid, "balancing the spacetree", balanceReport, true);
    }
    summary.Stages.push_back(balanceReport);
  }

  if (options.StopAfter == StopStage::Tessellate)
  {
    StageReport tessellateReport;
    tessellateReport.Name = "tessellate";
    vtkNew<stmSpacetreeTessellate> tessellate;
    grid = RunStage(tessellate, grid, "tessellating the spacetree", tessellateReport, false);
    summary.Stages.push_back(tessellateReport);
  }

  StageReport writeReport;
  writeReport.Name = "write";
  WriteMesh(grid, output, meshFormat, options.Compressor, writeReport);
  summary.Stages.push_back(writeReport);
  summary.TotalSeconds = SecondsSince(start);

  summary.MaterialKey = MaterialCountKey(grid, options.StopAfter);
  summary.CellsPerMaterial = CountCellsPerMaterial(grid);

  PrintTable(summary.Stages, summary.TotalSeconds);
  if (!options.SummaryPath.empty())
  {
    WriteSummary(options.SummaryPath, options, summary);
    std::cout << "summary: " << options.SummaryPath << '\n';
  }
  return 0;
}

void PrintErrorLines(const std::string& message)
{
  std::istringstream lines(message);
  std::string line;
  bool printed = false;
  while (std::getline(lines, line))
  {
    std::cerr << "stmesh: error: " << line << '\n';
    printed = true;
  }
  if (!printed)
  {
    std::cerr << "stmesh: error: unknown error\n";
  }
}
} // namespace

int main(int argc, char* argv[])
{
  try
  {
    Diagnostics(); // bind it to the real stderr before anything captures std::cerr
    // VTK's logger would print every message a second time, in colour, on stderr.
    vtkLogger::SetStderrVerbosity(vtkLogger::VERBOSITY_OFF);
    vtkNew<stmeshOutputWindow> outputWindow;
    vtkOutputWindow::SetInstance(outputWindow);
    for (int signalNumber : { SIGINT, SIGTERM, SIGHUP })
    {
      std::signal(signalNumber, RemovePendingTemporaryAndExit);
    }

    const Options options = ParseCommandLine(argc, argv);
    if (options.ShowHelp)
    {
      std::cout << UsageText;
      return 0;
    }
    if (options.ShowVersion)
    {
      std::cout << "stmesh (SpacetreeMesh) " << STMESH_VERSION << ", VTK "
                << vtkVersion::GetVTKVersion() << '\n';
      return 0;
    }
    const int status = Run(options);
    std::cout.flush();
    return status;
  }
  catch (const UsageError& error)
  {
    PrintErrorLines(error.what());
    std::cerr << "Try 'stmesh --help' for more information.\n";
    return 2;
  }
  catch (const std::bad_alloc&)
  {
    PrintErrorLines("out of memory (try a larger --max-cell-size, fewer --labels or a higher "
                    "--balance level)");
    return 1;
  }
  catch (const std::exception& error)
  {
    PrintErrorLines(error.what());
    return 1;
  }
  catch (...)
  {
    PrintErrorLines("unexpected internal error");
    return 1;
  }
}
