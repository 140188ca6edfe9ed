#include "svms/pipelines/item_failure.h"

#include <new>
#include <opencv2/core.hpp>

namespace svms {

std::string ItemFailure(const std::string& item, std::exception_ptr failure) {
  try {
    std::rethrow_exception(failure);
  } catch (const std::bad_alloc&) {
    return item + ": out of memory; expected a smaller image or fewer --threads";
  } catch (const cv::Exception& e) {
    if (e.code == cv::Error::StsNoMem)
      return item + ": out of memory (in OpenCV); expected a smaller image or fewer --threads";
    return item + ": OpenCV error: " + e.err;
  } catch (const std::exception& e) {
    return item + ": internal error: " + e.what();
  } catch (...) {
    return item + ": internal error";
  }
}

}  // namespace svms
