// SPDX-License-Identifier: BSD-3-Clause
#include "stmeshErrors.h"

#include "stmeshText.h"

#include "vtkAlgorithm.h"
#include "vtkCallbackCommand.h"
#include "vtkCommand.h"
#include "vtkExecutive.h"
#include "vtkLogger.h"
#include "vtkNew.h"
#include "vtkObjectFactory.h"
#include "vtkOutputWindow.h"

#include <cctype>
#include <iostream>

namespace stmesh
{

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

std::ostream& Diagnostics()
{
  static std::ostream stream(std::cerr.rdbuf());
  return stream;
}

void ErrorLog::Record(const std::string& message, bool fromExecutive)
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

bool ErrorLog::HasErrors()
{
  std::lock_guard<std::mutex> lock(this->Mutex);
  return !this->Messages.empty() || !this->ExecutiveMessages.empty();
}

std::string ErrorLog::Take()
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

ErrorLog& Errors()
{
  static ErrorLog log;
  return log;
}

namespace
{

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
  void DisplayWarningText(const char* text) override { HandleWarning(text); }
  void DisplayGenericWarningText(const char* text) override { HandleWarning(text); }
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

} // namespace

void InstallErrorCapture()
{
  Diagnostics(); // bind it to the real stderr before anything captures std::cerr
  vtkLogger::SetStderrVerbosity(vtkLogger::VERBOSITY_OFF);
  vtkNew<stmeshOutputWindow> outputWindow;
  vtkOutputWindow::SetInstance(outputWindow); // keeps a reference
}

StandardErrorCapture::StandardErrorCapture()
  : Saved(std::cerr.rdbuf(this->Captured.rdbuf()))
{
}

StandardErrorCapture::~StandardErrorCapture()
{
  std::cerr.rdbuf(this->Saved);
}

std::string StandardErrorCapture::GetText() const
{
  return Trim(this->Captured.str());
}

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

} // namespace stmesh
