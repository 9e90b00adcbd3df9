#pragma once
/// \file errors.hpp
/// The voxpack exception family. Library code throws these; only `main` catches
/// them (InputError/IoError/UsageError -> exit 2, anything else -> exit 1).

#include <stdexcept>
#include <string>

namespace voxpack {

/// Base of every voxpack exception.
class Error : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Bad input from the user: a value out of range, a malformed spec, a bad file content.
class InputError : public Error {
 public:
  using Error::Error;
};

/// A file cannot be opened, read or written.
class IoError : public Error {
 public:
  using Error::Error;
};

/// A bed/image file is readable but does not follow its format (docs/interfaces.md bed table).
class FormatError : public InputError {
 public:
  using InputError::InputError;
};

/// The command line itself is wrong (missing or conflicting options).
class UsageError : public InputError {
 public:
  using InputError::InputError;
};

/// The work would need more memory (or other resource) than its budget allows; the
/// message gives the estimate and the limit (exit 2: the user can raise the limit).
class ResourceError : public InputError {
 public:
  using InputError::InputError;
};

/// Long work stopped because the progress hook asked to cancel.
class Cancelled : public Error {
 public:
  using Error::Error;
};

/// A broken internal invariant: a bug, never the user's fault (exit 1).
class InternalError : public Error {
 public:
  using Error::Error;
};

}  // namespace voxpack
