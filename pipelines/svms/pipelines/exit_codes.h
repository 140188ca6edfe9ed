// The exit codes of the svms commands and of every pipeline that returns one
// (docs/conventions.md, "Errors and exit codes").
#pragma once

#include <iostream>
#include <string_view>

namespace svms {

// 0 success; 1 the work failed (or any item of a batch failed); 2 bad input that stopped the run
// before any work; 3 a benchmark ran and wrote its report but missed one of its targets.
constexpr int kExitOk = 0, kExitFailed = 1, kExitBadInput = 2, kExitTargetMissed = 3;

// Prints "PROGRAM: MESSAGE" as one line on stderr and returns kExitBadInput, for
// `return BadInput("svms pose", "...")` where bad input stops a command.
inline int BadInput(std::string_view program, std::string_view message) {
  std::cerr << program << ": " << message << "\n";
  return kExitBadInput;
}

}  // namespace svms
