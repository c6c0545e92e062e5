// SPDX-License-Identifier: BSD-3-Clause
#ifndef stmCoreStatus_h
#define stmCoreStatus_h

// The core reports failure as a value; it never throws across the VTK boundary.

#include <string>
#include <utility>

namespace stm
{

class Status
{
public:
  enum class Code
  {
    Ok,
    InvalidArgument,
    Aborted,
    OutOfRange
  };

  Status() = default;
  static Status Ok() { return Status(); }
  static Status Invalid(std::string message)
  {
    return Status(Code::InvalidArgument, std::move(message));
  }
  static Status Aborted() { return Status(Code::Aborted, "execution aborted"); }
  static Status OutOfRange(std::string message)
  {
    return Status(Code::OutOfRange, std::move(message));
  }

  bool IsOk() const { return this->StatusCode == Code::Ok; }
  Code GetCode() const { return this->StatusCode; }
  const std::string& GetMessage() const { return this->Message; }

private:
  Status(Code code, std::string message)
    : StatusCode(code)
    , Message(std::move(message))
  {
  }
  Code StatusCode = Code::Ok;
  std::string Message;
};

} // namespace stm

#endif
