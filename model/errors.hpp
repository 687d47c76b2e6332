// Error types of the model layer. Messages are meant for users: they say what was wrong
// and what to do.
#pragma once

#include <stdexcept>
#include <string>

namespace dtflop {

// Bad user input: a file, a flag, a size. The CLI prints what() on one line and exits 2.
class InputError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// A prediction needs a parameter the profile does not hold.
class MissingParameter : public InputError {
 public:
  using InputError::InputError;
};

}  // namespace dtflop
