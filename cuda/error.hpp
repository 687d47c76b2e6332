// The one error type of a failed CUDA call, for every part of dtflop that calls CUDA (probes,
// workloads). Plain C++: code that never includes a CUDA header can catch it.
#pragma once

#include <stdexcept>
#include <string>

#include "model/errors.hpp"

namespace dtflop::cuda {

// A CUDA call failed; the message names the call, where it was made, and CUDA's error.
class Error : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// A GPU path asked for where no CUDA device can be used (or dtflop was built without CUDA): bad
// input for this machine, so an InputError (one line, and the CLI's exit status 2).
class Unavailable : public InputError {
 public:
  using InputError::InputError;
};

}  // namespace dtflop::cuda
