// Typed exceptions thrown at setup and API boundaries. Inside a haptic tick nothing throws;
// these are for loading, preprocessing and command-line handling.
#pragma once

#include <stdexcept>
#include <string>

namespace palp {

// Base of every palp error. what() is a single line meant for the user.
class Error : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Input that cannot be read or is not what it claims to be (file formats, DICOM series).
class InputError : public Error {
 public:
  using Error::Error;
};

// A request that exceeds what this machine can do (absurd sizes, not enough memory).
class ResourceError : public Error {
 public:
  using Error::Error;
};

// Bad arguments or parameters given by the user.
class UsageError : public Error {
 public:
  using Error::Error;
};

}  // namespace palp
