#include "image_array.h"

#include <sstream>
#include <string>

namespace svms::python {
namespace {

std::string Describe(const py::array& a) {
  std::ostringstream s;
  s << py::str(a.dtype()).cast<std::string>() << " array of shape (";
  for (py::ssize_t i = 0; i < a.ndim(); ++i) s << (i ? ", " : "") << a.shape(i);
  s << (a.ndim() == 1 ? ",)" : ")") << " and strides (";
  for (py::ssize_t i = 0; i < a.ndim(); ++i) s << (i ? ", " : "") << a.strides(i);
  s << (a.ndim() == 1 ? ",)" : ")");
  return s.str();
}

[[noreturn]] void Refuse(const py::array& a, const char* what, const std::string& expected) {
  throw py::type_error(std::string(what) + ": expected " + expected + ", got a " + Describe(a));
}

}  // namespace

cv::Mat MatFromArray(const py::array& a, const char* what) {
  const char* kShapes =
      "a 2-D uint8 or uint16 array (H x W, grey) or H x W x 3 (BGR) with adjacent pixels in each "
      "row";
  const py::dtype dt = a.dtype();
  const bool u8 = dt.is(py::dtype::of<uint8_t>()) || (dt.kind() == 'u' && dt.itemsize() == 1);
  const bool u16 = dt.kind() == 'u' && dt.itemsize() == 2;
  if (!u8 && !u16) Refuse(a, what, kShapes);
  // A uint16 array in the other byte order ('>u2' on x86) would be read wrong.
  if (u16 && !dt.is(py::dtype::of<uint16_t>()) && dt.attr("byteorder").cast<std::string>() == ">")
    Refuse(a, what, "uint16 in the machine's byte order (image.astype('=u2') converts)");
  const py::ssize_t esz = dt.itemsize();
  int channels = 1;
  if (a.ndim() == 3 && a.shape(2) == 3) {
    channels = 3;
    if (a.strides(2) != esz || a.strides(1) != 3 * esz)
      Refuse(a, what, "the three channels of each pixel and the pixels of each row adjacent");
  } else if (a.ndim() == 2) {
    if (a.strides(1) != esz && a.shape(1) > 1)
      Refuse(a, what,
             "the pixels of each row adjacent in memory (a transposed or column-strided view is "
             "not; np.ascontiguousarray(image) makes a contiguous copy)");
  } else {
    Refuse(a, what, kShapes);
  }
  const py::ssize_t rows = a.shape(0), cols = a.shape(1);
  if (rows < 1 || cols < 1) Refuse(a, what, "at least 1 x 1 pixels");
  const py::ssize_t row_bytes = cols * channels * esz;
  py::ssize_t step = a.strides(0);
  if (rows == 1) step = row_bytes;  // numpy may give any stride to an axis of length 1
  if (step < row_bytes || step % esz != 0)
    Refuse(a, what,
           "rows that do not overlap and start a whole number of elements apart (a flipped or "
           "row-interleaved view is not; np.ascontiguousarray(image) makes a contiguous copy)");
  const int type = CV_MAKETYPE(u8 ? CV_8U : CV_16U, channels);
  // The detector only reads the pixels: a read-only array is fine.
  return cv::Mat(static_cast<int>(rows), static_cast<int>(cols), type,
                 const_cast<void*>(a.data()), static_cast<size_t>(step));
}

}  // namespace svms::python
