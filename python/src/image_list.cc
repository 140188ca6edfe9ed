#include "image_list.h"

#include <algorithm>
#include <atomic>
#include <exception>
#include <optional>
#include <thread>

#include "image_array.h"

namespace svms::python {

std::vector<cv::Mat> MatsFromList(const py::handle& images, std::vector<py::array>* keep) {
  std::vector<cv::Mat> mats;
  if (py::isinstance<py::array>(images) || py::isinstance<py::str>(images))
    throw py::type_error("images: expected a list of images (numpy arrays), got one " +
                         py::str(py::type::of(images)).cast<std::string>());
  size_t i = 0;
  for (py::handle h : images) {
    const std::string what = "images[" + std::to_string(i++) + "]";
    if (!py::isinstance<py::array>(h))
      throw py::type_error(what + ": expected a numpy array, got " +
                           py::str(py::type::of(h)).cast<std::string>());
    keep->push_back(py::reinterpret_borrow<py::array>(h));
    mats.push_back(MatFromArray(keep->back(), what.c_str()));
  }
  return mats;
}

std::vector<std::string> ImageNames(const std::optional<std::vector<std::string>>& names,
                                    size_t count) {
  if (names) {
    if (names->size() != count)
      throw py::value_error("names: " + std::to_string(names->size()) + " names for " +
                            std::to_string(count) + " images; expected one per image");
    return *names;
  }
  std::vector<std::string> out;
  for (size_t i = 0; i < count; ++i) out.push_back("image " + std::to_string(i));
  return out;
}

std::vector<std::vector<Detection>> DetectAll(const Detector& detector,
                                              const std::vector<cv::Mat>& images, int threads) {
  std::vector<std::vector<Detection>> found(images.size());
  py::gil_scoped_release release;
  std::atomic<size_t> next{0};
  std::vector<std::exception_ptr> failed(images.size());
  auto worker = [&] {
    for (size_t i; (i = next++) < images.size();) {
      try {
        found[i] = detector.Detect(images[i]);
      } catch (...) {
        failed[i] = std::current_exception();
      }
    }
  };
  std::vector<std::thread> pool;
  const int n = std::max(1, std::min<int>(threads, static_cast<int>(images.size())));
  for (int t = 1; t < n; ++t) pool.emplace_back(worker);
  worker();
  for (std::thread& t : pool) t.join();
  for (const std::exception_ptr& e : failed)
    if (e) std::rethrow_exception(e);
  return found;
}

}  // namespace svms::python
