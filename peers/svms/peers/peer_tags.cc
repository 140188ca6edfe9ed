#include "svms/peers/peer_tags.h"

#include <cstdlib>
#include <opencv2/aruco.hpp>

extern "C" {
#include <apriltag/apriltag.h>
#include <apriltag/tag36h11.h>
}

namespace svms {

std::vector<std::string> PeerFamilies() { return {kTag36h11, kAruco6x6}; }

int PeerIdCount(const std::string& family) {
  if (family == kTag36h11) return 587;
  if (family == kAruco6x6) return 1000;
  return 0;
}

Status MakePeerTag(const std::string& family, int id, PrintedTag* out) {
  const int count = PeerIdCount(family);
  if (count == 0)
    return Status::Error("peer family \"" + family + "\": expected tag36h11 or aruco6x6");
  if (id < 0 || id >= count)
    return Status::Error("peer " + family + " ID " + std::to_string(id) + ": expected 0.." +
                         std::to_string(count - 1));
  PrintedTag t;
  t.family = family;
  t.n = 8;
  t.white.assign(64, 0);
  if (family == kTag36h11) {
    // apriltag_to_image draws the 10 x 10 tag with its white outer border; the black edge is
    // the inner 8 x 8. (image_u8_destroy is not exported by Debian's libapriltag 3.3: the
    // image is freed by hand, as image_u8_destroy does it: buffer, then struct.)
    apriltag_family_t* tf = tag36h11_create();
    image_u8_t* im = apriltag_to_image(tf, static_cast<uint32_t>(id));
    const int off = (im->width - 8) / 2;
    for (int r = 0; r < 8; ++r)
      for (int c = 0; c < 8; ++c)
        t.white[r * 8 + c] = im->buf[(r + off) * im->stride + c + off] > 127;
    std::free(im->buf);
    std::free(im);
    tag36h11_destroy(tf);
  } else {
    const cv::Ptr<cv::aruco::Dictionary> dict =
        cv::aruco::getPredefinedDictionary(cv::aruco::DICT_6X6_1000);
    cv::Mat img;
    dict->drawMarker(id, 8, img, 1);
    for (int r = 0; r < 8; ++r)
      for (int c = 0; c < 8; ++c) t.white[r * 8 + c] = img.at<uint8_t>(r, c) > 127;
  }
  for (int i = 0; i < 8; ++i)
    for (int k : {t.white[i], t.white[56 + i], t.white[i * 8], t.white[i * 8 + 7]})
      if (k) return Status::Error("peer " + family + ": the drawn tag has no black border");
  *out = std::move(t);
  return Status::Ok();
}

Status AsPeerMarker(const SceneMarker& svms, const std::string& family, int id, SceneMarker* out) {
  SceneMarker m = svms;
  if (Status s = MakePeerTag(family, id, &m.print); !s) return s;
  m.model.id = id;
  m.model.post.reset();
  m.model.inner.reset();
  *out = std::move(m);
  return Status::Ok();
}

}  // namespace svms
