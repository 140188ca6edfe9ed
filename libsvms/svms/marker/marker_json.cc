#include "svms/marker/marker_json.h"

namespace svms::json_fields {

MarkerModel ParseMarker(const json& j, const std::string& path, bool top_level) {
  std::set<std::string> keys{"family", "id", "size", "stripe_width", "cell_size", "post", "inner"};
  if (top_level) keys.insert("type");
  CheckKeys(j, path, keys);
  MarkerModel m;
  m.family = String(j, path, "family");
  m.id = Integer(j, path, "id");
  m.size = Number(j, path, "size");
  m.stripe_width = Number(j, path, "stripe_width");
  m.cell_size = Number(j, path, "cell_size");
  auto parse_post = [](const json& p, const std::string& pp) {
    CheckKeys(p, pp, {"height", "radius", "tip_radius"});
    return PostModel{Number(p, pp, "height"), Number(p, pp, "radius"), Number(p, pp, "tip_radius")};
  };
  if (j.contains("post")) m.post = parse_post(j["post"], Join(path, "post"));
  if (j.contains("inner")) {
    const std::string ip = Join(path, "inner");
    const json& in = j["inner"];
    CheckKeys(in, ip, {"id", "size", "stripe_width", "cell_size", "post"});
    NestedMarker n;
    n.id = Integer(in, ip, "id");
    n.size = Number(in, ip, "size");
    n.stripe_width = Number(in, ip, "stripe_width");
    n.cell_size = Number(in, ip, "cell_size");
    m.inner = n;
    // The dual marker has one post at the common centre; it may be written in either place.
    if (in.contains("post")) {
      const PostModel p = parse_post(in["post"], Join(ip, "post"));
      if (m.post && (m.post->height != p.height || m.post->radius != p.radius ||
                     m.post->tip_radius != p.tip_radius)) {
        throw FieldError{Join(ip, "post") + ": a dual marker has one post at the common centre; " +
                         "expected it in one place (or the same in both), got two different posts"};
      }
      m.post = p;
    }
  }
  if (Status s = m.Validate(path.empty() ? "" : path + "."); !s) throw FieldError{s.message()};
  return m;
}

json MarkerJson(const MarkerModel& m) {
  json j;
  j["family"] = m.family;
  j["id"] = m.id;
  j["size"] = m.size;
  j["stripe_width"] = m.stripe_width;
  j["cell_size"] = m.cell_size;
  if (m.post)
    j["post"] = {
        {"height", m.post->height}, {"radius", m.post->radius}, {"tip_radius", m.post->tip_radius}};
  if (m.inner) {
    j["inner"] = {{"id", m.inner->id},
                  {"size", m.inner->size},
                  {"stripe_width", m.inner->stripe_width},
                  {"cell_size", m.inner->cell_size}};
  }
  return j;
}

}  // namespace svms::json_fields
