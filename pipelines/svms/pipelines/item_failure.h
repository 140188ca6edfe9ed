// What ended the work on one item of a batch (an image, a view), as one line.
#pragma once

#include <exception>
#include <string>

namespace svms {

// One line for an exception that ended the work on one item of a batch (`item`: the file):
// out of memory (std::bad_alloc, or OpenCV's StsNoMem), another OpenCV error, or an internal
// error. Called from `catch (...)` with std::current_exception(), so that nothing escapes a
// worker thread (which would abort the process).
std::string ItemFailure(const std::string& item, std::exception_ptr failure);

}  // namespace svms
