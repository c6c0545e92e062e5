// SPDX-License-Identifier: BSD-3-Clause
#ifndef stmeshErrors_h
#define stmeshErrors_h

// How stmesh turns VTK's errors into failures. VTK reports errors through vtkErrorMacro, which
// does not throw, so every reader, filter, writer and executive gets an ErrorEvent observer
// (Watch), the output window (which receives the errors of objects without observers) is
// replaced (InstallErrorCapture), and any recorded error fails the step (ThrowIfFailed).

#include <iosfwd>
#include <mutex>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

class vtkAlgorithm;

namespace stmesh
{

/// A failure of the run; each line of what() becomes one "stmesh: error:" line on stderr.
class Failure : public std::runtime_error
{
public:
  explicit Failure(const std::string& message)
    : std::runtime_error(message)
  {
  }
};

/// VTK messages look like "ERROR: In file.cxx, line 12\nvtkClass (0x55d0c0): text\n\n"; this
/// keeps "vtkClass: text", which is what a user can act on.
std::string CleanVTKMessage(const std::string& message);

/// stderr as it was at start-up. While a reader runs, std::cerr is captured (see
/// StandardErrorCapture), so stmesh's own warnings go through this stream instead.
std::ostream& Diagnostics();

/// All VTK errors of the run, in order. The executives' "Algorithm X returned failure for
/// request" only repeats that a filter failed, so it is kept apart and shown only when nothing
/// more specific was reported.
class ErrorLog
{
public:
  void Record(const std::string& message, bool fromExecutive);
  bool HasErrors();
  /// The recorded messages, one per line, and a clean log for the next stage.
  std::string Take();

private:
  std::mutex Mutex;
  std::vector<std::string> Messages;
  std::vector<std::string> ExecutiveMessages;
};

ErrorLog& Errors();

/// Binds Diagnostics() to the real stderr, silences VTK's logger on stderr (it would repeat every
/// message) and replaces VTK's output window: errors go to Errors(), warnings to Diagnostics(),
/// nothing to stdout, which carries stmesh's table.
void InstallErrorCapture();

/// MetaIO (inside vtkMetaImageReader) reports problems such as "data not read completely" on
/// std::cerr instead of through VTK, and the reader still succeeds. Everything written to
/// std::cerr while an instance lives is kept, to be treated as an error.
class StandardErrorCapture
{
public:
  StandardErrorCapture();
  ~StandardErrorCapture();

  std::string GetText() const;

private:
  std::ostringstream Captured;
  std::streambuf* Saved;

  StandardErrorCapture(const StandardErrorCapture&) = delete;
  void operator=(const StandardErrorCapture&) = delete;
};

/// Observe the errors (and warnings) of an algorithm and of its executive.
void Watch(vtkAlgorithm* algorithm);

/// Throw the recorded errors, if any, with the context ("reading 'x.nii'") on every line.
void ThrowIfFailed(const std::string& context);

} // namespace stmesh

#endif
