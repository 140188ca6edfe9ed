#include "svms/marker/marker_model.h"

#include <cmath>
#include <cstdio>

#include "svms/base/format.h"
#include "svms/codec/svms44.h"

namespace svms {
namespace {

constexpr double kGeometryTolerance = 1e-6;  // metres: 1 micrometre

Status CheckRing(const std::string& where, double size, double stripe, double cell) {
  if (!(std::isfinite(size) && size > 0))
    return Status::Error(where + "size: expected a positive number of metres, got " +
                         Significant(size, 9));
  if (!(std::isfinite(stripe) && stripe > 0))
    return Status::Error(where + "stripe_width: expected a positive number of metres, got " +
                         Significant(stripe, 9));
  if (!(std::isfinite(cell) && cell > 0))
    return Status::Error(where + "cell_size: expected a positive number of metres, got " +
                         Significant(cell, 9));
  if (std::abs(0.5 * size + stripe - 5 * cell) > kGeometryTolerance) {
    return Status::Error(where + "cell_size: expected size / 2 + stripe_width = 5 * cell_size (" +
                         Significant((0.5 * size + stripe) / 5, 9) +
                         " m for this size and stripe), got " + Significant(cell, 9));
  }
  return Status::Ok();
}

Status CheckId(const std::string& field, int id) {
  if (id < 0 || id >= Svms44::kNumIds) {
    return Status::Error(field + ": expected an svms44 ID in [0, " +
                         std::to_string(Svms44::kNumIds - 1) + "], got " + std::to_string(id));
  }
  return Status::Ok();
}

}  // namespace

MarkerModel MarkerModel::Standard(int id, double size, double post_height) {
  MarkerModel m;
  m.id = id;
  m.size = size;
  m.cell_size = size / 6;
  m.stripe_width = 5 * m.cell_size - 0.5 * size;
  if (post_height != 0) m.post = PostModel{post_height, size / 20, size / 20};
  return m;
}

void MarkerModel::AddInner(int inner_id, double inner_size) {
  NestedMarker n;
  n.id = inner_id;
  n.size = inner_size;
  n.cell_size = inner_size / 6;
  n.stripe_width = 5 * n.cell_size - 0.5 * inner_size;
  inner = n;
}

std::array<Eigen::Vector3d, 4> MarkerModel::Corners() const {
  const double h = 0.5 * size;
  return {Eigen::Vector3d(-h, h, 0), Eigen::Vector3d(h, h, 0), Eigen::Vector3d(h, -h, 0),
          Eigen::Vector3d(-h, -h, 0)};
}

std::optional<Eigen::Vector3d> MarkerModel::PostTip() const {
  if (!post) return std::nullopt;
  return Eigen::Vector3d(0, 0, post->height);
}

Eigen::Vector2d MarkerModel::BitCellCentre(int i) const {
  const int side = i / Svms44::kBitsPerSide, k = i % Svms44::kBitsPerSide;
  const double edge = 5.5 * cell_size, along = -5.5 * cell_size + k * cell_size;
  switch (side) {
    case 0:
      return {along, edge};  // top, left to right
    case 1:
      return {edge, -along};  // right, top to bottom
    case 2:
      return {-along, -edge};  // bottom, right to left
    default:
      return {-edge, along};  // left, bottom to top
  }
}

std::optional<MarkerModel> MarkerModel::InnerModel() const {
  if (!inner) return std::nullopt;
  MarkerModel m;
  m.family = family;
  m.id = inner->id;
  m.size = inner->size;
  m.stripe_width = inner->stripe_width;
  m.cell_size = inner->cell_size;
  m.post = post;
  return m;
}

Status MarkerModel::Validate(const std::string& path) const {
  if (family != Svms44::kFamily)
    return Status::Error(path + "family: expected \"svms44\", got \"" + family + "\"");
  if (Status s = CheckId(path + "id", id); !s) return s;
  if (Status s = CheckRing(path, size, stripe_width, cell_size); !s) return s;
  double innermost = size;
  if (inner) {
    const std::string ip = path + "inner.";
    if (Status s = CheckId(ip + "id", inner->id); !s) return s;
    if (inner->id == id)
      return Status::Error(ip + "id: expected an ID different from the outer marker's " +
                           std::to_string(id));
    if (Status s = CheckRing(ip, inner->size, inner->stripe_width, inner->cell_size); !s) return s;
    // The inner marker's ring plus one inner cell of black margin must fit in the black square.
    const double needed = 2 * (6 * inner->cell_size + inner->cell_size);
    if (needed > size + kGeometryTolerance) {
      return Status::Error(ip + "size: the inner marker with a one-cell margin needs " +
                           Significant(needed, 9) + " m, more than the outer black square (" +
                           Significant(size, 9) + " m)");
    }
    innermost = inner->size;
  }
  if (post) {
    const std::string pp = path + "post.";
    if (!std::isfinite(post->height) || post->height == 0)
      return Status::Error(pp + "height: expected a nonzero number of metres (> 0 post, < 0 " +
                           "concave well), got " + Significant(post->height, 9));
    if (!(std::isfinite(post->radius) && post->radius > 0 && post->radius <= 0.25 * innermost))
      return Status::Error(pp + "radius: expected a positive number of metres up to a quarter of " +
                           "the innermost black square (" + Significant(0.25 * innermost, 9) +
                           "), got " + Significant(post->radius, 9));
    if (!(std::isfinite(post->tip_radius) && post->tip_radius > 0 &&
          post->tip_radius <= post->radius + kGeometryTolerance))
      return Status::Error(pp + "tip_radius: expected a positive number of metres up to radius (" +
                           Significant(post->radius, 9) + "), got " +
                           Significant(post->tip_radius, 9));
  }
  return Status::Ok();
}

std::string MarkerModel::Summary() const {
  char buf[256];
  std::string s;
  if (inner) {
    std::snprintf(buf, sizeof buf, "dual marker %d/%d (%s), %.4g/%.4g m", id, inner->id,
                  family.c_str(), size, inner->size);
  } else {
    std::snprintf(buf, sizeof buf, "marker %d (%s), %.4g m", id, family.c_str(), size);
  }
  s = buf;
  if (post) {
    std::snprintf(buf, sizeof buf, ", %s %+.4g m", post->concave() ? "concave well" : "post",
                  post->height);
    s += buf;
  } else {
    s += ", flat";
  }
  return s;
}

}  // namespace svms
