// What the palp.v1 decoders share: the ProtocolViolation error and positive_finite().
#pragma once

#include <cmath>

#include "base/errors.hpp"

namespace palp::view::net {

// A violation of palp.v1 by the server: the connection is dropped with this message.
class ProtocolViolation : public InputError {
 public:
  using InputError::InputError;
};

inline bool positive_finite(double v) {
  return std::isfinite(v) && v > 0.0;
}

}  // namespace palp::view::net
