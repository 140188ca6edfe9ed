#include "svms/marker/model_io.h"

#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

namespace svms {
namespace {

using nlohmann::json;

json GoodMarker() {
  return json::parse(MarkerModelToJson([] {
    MarkerModel m = MarkerModel::Standard(17, 0.2, 0.05);
    return m;
  }()));
}

// Parses and expects failure whose message contains every one of `parts`.
void ExpectError(const json& j, std::initializer_list<std::string> parts) {
  ModelFile f;
  const Status s = ParseModelJson(j.dump(), "bad.json", &f);
  ASSERT_FALSE(s.ok()) << j.dump();
  EXPECT_EQ(s.message().find('\n'), std::string::npos) << "one line: " << s.message();
  EXPECT_EQ(s.message().rfind("bad.json: ", 0), 0u) << s.message();
  for (const std::string& p : parts)
    EXPECT_NE(s.message().find(p), std::string::npos) << s.message();
}

TEST(ModelIo, MarkerRoundTripsExactly) {
  MarkerModel m = MarkerModel::Standard(3, 0.432, 0.1);
  m.AddInner(4, 0.108);
  ModelFile f;
  ASSERT_TRUE(ParseModelJson(MarkerModelToJson(m), "m.json", &f).ok());
  ASSERT_EQ(f.kind, ModelFile::Kind::kMarker);
  const MarkerModel& r = f.markers[0];
  EXPECT_EQ(r.id, 3);
  EXPECT_EQ(r.size, m.size);
  EXPECT_EQ(r.cell_size, m.cell_size);
  EXPECT_EQ(r.stripe_width, m.stripe_width);
  ASSERT_TRUE(r.post && r.inner);
  EXPECT_EQ(r.post->height, 0.1);
  EXPECT_EQ(r.inner->id, 4);
  EXPECT_EQ(r.inner->size, 0.108);
  EXPECT_EQ(MarkerModelToJson(r), MarkerModelToJson(m));
  EXPECT_EQ(f.Summary(), "dual marker 3/4 (svms44), 0.432/0.108 m, post +0.1 m");
}

TEST(ModelIo, LayoutRoundTripsWithCovariance) {
  Layout l;
  l.name = "mockup";
  LayoutEntry e;
  e.marker = MarkerModel::Standard(1, 0.1, 0.02);
  e.object_from_marker.rvec = Eigen::Vector3d(0.1, -0.2, 0.3);
  e.object_from_marker.tvec = Eigen::Vector3d(1, 2, 3);
  PoseCovariance c = PoseCovariance::Identity() * 1e-6;
  c(0, 3) = c(3, 0) = 1e-7;
  e.covariance = c;
  e.post_height_sigma = 1e-4;
  l.markers.push_back(e);
  e.marker = MarkerModel::Standard(2, 0.2, -0.03);
  e.object_from_marker.tvec = Eigen::Vector3d(1, 2, 4);  // apart from marker 1
  e.covariance.reset();
  e.post_height_sigma.reset();
  l.markers.push_back(e);
  ModelFile f;
  ASSERT_TRUE(ParseModelJson(LayoutToJson(l), "l.json", &f).ok());
  ASSERT_EQ(f.kind, ModelFile::Kind::kLayout);
  ASSERT_EQ(f.layout.markers.size(), 2u);
  EXPECT_EQ(*f.layout.markers[0].covariance, c);
  EXPECT_EQ(f.layout.markers[0].object_from_marker.rvec, e.object_from_marker.rvec);
  EXPECT_FALSE(f.layout.markers[1].covariance);
  EXPECT_EQ(f.markers.size(), 2u);
  EXPECT_NE(f.layout.Find(2), nullptr);
  EXPECT_EQ(f.layout.Find(5), nullptr);
  EXPECT_EQ(LayoutToJson(f.layout), LayoutToJson(l));
}

TEST(ModelIo, MarkerSetParses) {
  json j = {{"type", "svms.markers"}, {"markers", json::array()}};
  json a = GoodMarker(), b = GoodMarker();
  a.erase("type");
  b.erase("type");
  b["id"] = 18;
  j["markers"] = {a, b};
  ModelFile f;
  ASSERT_TRUE(ParseModelJson(j.dump(), "s.json", &f).ok());
  EXPECT_EQ(f.kind, ModelFile::Kind::kMarkerSet);
  EXPECT_EQ(f.markers.size(), 2u);
}

TEST(ModelIo, SyntaxErrorNamesLineAndColumn) {
  ModelFile f;
  const Status s =
      ParseModelJson("{\n  \"type\": \"svms.marker\",\n  \"id\": ,\n}", "bad.json", &f);
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.message().find("bad.json: line 3"), std::string::npos) << s.message();
}

TEST(ModelIo, MissingFileIsNamed) {
  ModelFile f;
  const Status s = ReadModelFile("/nonexistent/m.json", &f);
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.message(), "/nonexistent/m.json: cannot open for reading: No such file or directory");
}

TEST(ModelIo, EachBadFieldIsNamed) {
  json j;
  j = GoodMarker();
  j.erase("type");
  ExpectError(j, {"type: missing"});
  j = GoodMarker();
  j["type"] = "svms.thing";
  ExpectError(j, {"type: expected", "svms.thing"});
  j = GoodMarker();
  j["family"] = "tag36h11";
  ExpectError(j, {"family: expected \"svms44\""});
  j = GoodMarker();
  j.erase("size");
  ExpectError(j, {"size: missing"});
  j = GoodMarker();
  j["size"] = -0.2;
  ExpectError(j, {"size: expected a positive", "-0.2"});
  j = GoodMarker();
  j["size"] = 0;
  ExpectError(j, {"size: expected a positive"});
  j = GoodMarker();
  j["size"] = "0.2";
  ExpectError(j, {"size: expected a number", "string"});
  j = GoodMarker();
  j["id"] = 40000;
  ExpectError(j, {"id: expected an svms44 ID", "40000"});
  j = GoodMarker();
  j["id"] = 1.5;
  ExpectError(j, {"id: expected an integer"});
  j = GoodMarker();
  j["cell_size"] = 0.05;
  ExpectError(j, {"cell_size: expected size / 2 + stripe_width = 5 * cell_size"});
  j = GoodMarker();
  j["stripe_widht"] = 0.1;
  ExpectError(j, {"stripe_widht: unknown field"});
  j = GoodMarker();
  j["post"]["height"] = 0;
  ExpectError(j, {"post.height: expected a nonzero"});
  j = GoodMarker();
  j["post"]["radius"] = 0.2;
  ExpectError(j, {"post.radius: expected"});
  j = GoodMarker();
  j["post"]["tip_radius"] = 0.02;
  ExpectError(j, {"post.tip_radius: expected"});
  j = GoodMarker();
  j["post"].erase("radius");
  ExpectError(j, {"post.radius: missing"});
  j = GoodMarker();
  j["inner"] = {
      {"id", 17}, {"size", 0.05}, {"stripe_width", 5 * 0.05 / 6 - 0.025}, {"cell_size", 0.05 / 6}};
  ExpectError(j, {"inner.id: expected an ID different"});
  j["inner"]["id"] = 5;
  j["inner"]["size"] = 0.15;
  j["inner"]["cell_size"] = 0.025;
  j["inner"]["stripe_width"] = 0.05;
  ExpectError(j, {"inner.size: the inner marker with a one-cell margin needs"});
  j = GoodMarker();
  j["inner"] = {{"id", 5},
                {"size", 0.05},
                {"stripe_width", 5 * 0.05 / 6 - 0.025},
                {"cell_size", 0.05 / 6},
                {"post", {{"height", 0.01}, {"radius", 0.001}, {"tip_radius", 0.001}}}};
  ExpectError(j, {"inner.post: a dual marker has one post"});
  ExpectError(json::array(), {"(top level): expected an object"});
}

TEST(ModelIo, LayoutErrorsAreNamed) {
  json m = GoodMarker();
  m.erase("type");
  json entry = {{"marker", m}, {"object_from_marker", {{"rvec", {0, 0, 0}}, {"tvec", {0, 0, 1}}}}};
  json l = {{"type", "svms.layout"}, {"name", "x"}, {"markers", {entry, entry}}};
  ExpectError(l, {"markers[1].marker.id: ID 17 appears twice"});
  l["markers"] = json::array();
  ExpectError(l, {"markers: expected a non-empty array"});
  json e = entry;
  e["object_from_marker"]["tvec"] = {0, 0};
  // json::array, not `= {e}`: clang takes a one-element braced list for a copy of e (an object),
  // gcc for an array of it, so with it the cases below would test "not an array" under clang.
  l["markers"] = json::array({e});
  ExpectError(l, {"markers[0].object_from_marker.tvec: expected an array of 3 numbers"});
  e = entry;
  e["covariance"] = std::vector<double>(35, 0.0);
  l["markers"] = json::array({e});
  ExpectError(l, {"markers[0].covariance: expected an array of 36 numbers"});
  std::vector<double> cov(36, 0.0);
  cov[0] = -1;
  e["covariance"] = cov;
  l["markers"] = json::array({e});
  ExpectError(l, {"markers[0].covariance: expected a positive semi-definite"});
  cov[0] = 1;
  cov[1] = 0.5;
  e["covariance"] = cov;
  l["markers"] = json::array({e});
  ExpectError(l, {"markers[0].covariance: expected a symmetric"});
  e = entry;
  e["marker"]["size"] = -1;
  l["markers"] = json::array({e});
  ExpectError(l, {"markers[0].marker.size: expected a positive"});
}

// Parses `j` with the number 12345.678 replaced by `literal` in its text (JSON objects cannot
// hold infinity, but a file can hold a literal that overflows a double).
void ExpectTextError(const json& j, const std::string& literal,
                     std::initializer_list<std::string> parts) {
  std::string text = j.dump();
  const size_t at = text.find("12345.678");
  ASSERT_NE(at, std::string::npos);
  text.replace(at, 9, literal);
  ModelFile f;
  const Status s = ParseModelJson(text, "bad.json", &f);
  ASSERT_FALSE(s.ok()) << text;
  EXPECT_EQ(s.message().find('\n'), std::string::npos) << s.message();
  for (const std::string& p : parts)
    EXPECT_NE(s.message().find(p), std::string::npos) << s.message();
}

TEST(ModelIo, NumbersBeyondADoubleAreNamed) {
  json m = GoodMarker();
  m["size"] = 12345.678;
  // nlohmann refuses the literal while parsing: the message gives its place and value.
  ExpectTextError(m, "1e400",
                  {"bad.json: line 1, column ",
                   ": size: the number 1e400 is beyond the range of a "
                   "double; expected a finite number"});
  ExpectTextError(m, "-1e400", {"bad.json: line 1", "the number -1e400 is beyond"});
  ExpectTextError(m, "NaN", {"bad.json: line 1", "not valid JSON"});
  ExpectTextError(m, "Infinity", {"not valid JSON"});
  m = GoodMarker();
  m["post"]["height"] = 12345.678;
  ExpectTextError(m, "1e999", {"height: the number 1e999 is beyond the range of a double"});
  json inner = GoodMarker();
  inner.erase("type");
  inner["stripe_width"] = 12345.678;
  ExpectTextError(json{{"type", "svms.markers"}, {"markers", {inner}}}, "1e400",
                  {"the number 1e400 is beyond"});
  json entry = {{"marker", inner},
                {"object_from_marker", {{"rvec", {0, 0, 0}}, {"tvec", {0, 0, 1}}}}};
  entry["marker"]["stripe_width"] = GoodMarker()["stripe_width"];
  json l = {{"type", "svms.layout"}, {"name", "x"}, {"markers", {entry}}};
  l["markers"][0]["object_from_marker"]["tvec"][1] = 12345.678;
  ExpectTextError(l, "1e400", {"tvec: the number 1e400 is beyond"});
  l["markers"][0]["object_from_marker"]["tvec"][1] = 0;
  std::vector<double> cov(36, 0.0);
  cov[7] = 12345.678;
  l["markers"][0]["covariance"] = cov;
  ExpectTextError(l, "-1e400", {"covariance: the number -1e400 is beyond"});
  l["markers"][0].erase("covariance");
  l["markers"][0]["post_height_sigma"] = 12345.678;
  ExpectTextError(l, "1e400", {"post_height_sigma: the number 1e400 is beyond"});
}

TEST(ModelIo, LayoutOverlapsAndDuplicatesAreNamed) {
  json m = GoodMarker();  // size 0.2: printed side 0.4 m
  m.erase("type");
  auto entry = [&](int id, double x, double z) {
    json e = {{"marker", m}, {"object_from_marker", {{"rvec", {0, 0, 0}}, {"tvec", {x, 0, z}}}}};
    e["marker"]["id"] = id;
    return e;
  };
  json l = {
      {"type", "svms.layout"}, {"name", "x"}, {"markers", {entry(1, 0, 0), entry(2, 0.4, 0)}}};
  ModelFile f;
  const Status ok = ParseModelJson(l.dump(), "l.json", &f);
  EXPECT_TRUE(ok.ok()) << "touching markers are fine: " << ok.message();
  l["markers"] = {entry(1, 0, 0), entry(2, 0.3, 0.001)};
  ExpectError(l, {"markers[1].object_from_marker: marker 2 overlaps markers[0]", "same plane"});
  l["markers"] = {entry(1, 0, 0), entry(2, 0.05, 0.05)};
  ExpectError(l, {"markers[1].object_from_marker: marker 2 overlaps markers[0]",
                  "closer than half the smaller black square (0.1 m)"});
  l["markers"] = {entry(1, 0, 0), entry(2, 1, 0), entry(1, 2, 0)};
  ExpectError(l, {"markers[2].marker.id: ID 1 appears twice (also in markers[0])"});
  json set = {{"type", "svms.markers"}, {"markers", {m, m}}};
  ExpectError(set, {"markers[1].id: ID 17 appears twice"});
}

// A key written twice would otherwise be read as its last value (nlohmann's choice; JSON leaves
// it undefined): every JSON reader refuses it, naming where.
TEST(ModelIo, DuplicateKeysAreRefusedWithTheirPath) {
  const std::string marker = MarkerModelToJson(MarkerModel::Standard(17, 0.2, 0.05));
  std::string twice = marker;
  twice.insert(twice.find("\"id\""), "\"id\": 18, ");
  ModelFile f;
  Status s = ParseModelJson(twice, "m.json", &f);
  EXPECT_EQ(s.message(),
            "m.json: id: the field appears twice in one object; expected each field once (JSON "
            "does not say which would count)");
  Layout layout;
  layout.name = "t";
  layout.markers.push_back({MarkerModel::Standard(1, 0.2, 0), Pose(), {}, {}});
  layout.markers.push_back({MarkerModel::Standard(2, 0.2, 0), Pose{{0, 0, 0}, {1, 0, 0}}, {}, {}});
  std::string text = LayoutToJson(layout);
  ASSERT_TRUE(ParseModelJson(text, "l.json", &f).ok());
  const size_t second =
      text.find("\"object_from_marker\"", text.find("\"object_from_marker\"") + 1);
  text.insert(second, "\"object_from_marker\": {\"rvec\": [0, 0, 0], \"tvec\": [14, 0, 0]}, ");
  s = ParseModelJson(text, "l.json", &f);
  EXPECT_NE(s.message().find("l.json: markers[1].object_from_marker: the field appears twice"),
            std::string::npos)
      << s.message();
  // The same key in two different objects is fine; so are equal values in an array.
  EXPECT_TRUE(ParseModelJson(LayoutToJson(layout), "l.json", &f).ok());
}

TEST(ModelIo, NestingIsBounded) {
  ModelFile f;
  const Status s = ParseModelJson(std::string(100000, '['), "deep.json", &f);
  EXPECT_NE(s.message().find("deep.json: "), std::string::npos);
  EXPECT_NE(s.message().find("nested deeper than 64 levels"), std::string::npos) << s.message();
  // 63 levels are read (and refused for what they are, not for their depth).
  const Status ok_depth =
      ParseModelJson(std::string(63, '[') + std::string(63, ']'), "shallow.json", &f);
  EXPECT_EQ(ok_depth.message().find("nested"), std::string::npos) << ok_depth.message();
}

TEST(MarkerModel, GeometryFollowsTheConventions) {
  const MarkerModel m = MarkerModel::Standard(0, 0.12, 0.03);
  EXPECT_DOUBLE_EQ(m.cell_size, 0.02);
  EXPECT_DOUBLE_EQ(m.stripe_width, 0.04);
  EXPECT_DOUBLE_EQ(m.half_extent(), 0.12);
  const auto c = m.Corners();
  EXPECT_EQ(c[0], Eigen::Vector3d(-0.06, 0.06, 0));  // top-left
  EXPECT_EQ(c[2], Eigen::Vector3d(0.06, -0.06, 0));  // bottom-right
  EXPECT_EQ(*m.PostTip(), Eigen::Vector3d(0, 0, 0.03));
  // Bit 0: top-left cell; 11: top-right; 22: bottom-right; 33: bottom-left.
  EXPECT_TRUE(m.BitCellCentre(0).isApprox(Eigen::Vector2d(-0.11, 0.11)));
  EXPECT_TRUE(m.BitCellCentre(10).isApprox(Eigen::Vector2d(0.09, 0.11)));
  EXPECT_TRUE(m.BitCellCentre(11).isApprox(Eigen::Vector2d(0.11, 0.11)));
  EXPECT_TRUE(m.BitCellCentre(22).isApprox(Eigen::Vector2d(0.11, -0.11)));
  EXPECT_TRUE(m.BitCellCentre(33).isApprox(Eigen::Vector2d(-0.11, -0.11)));
  // A quarter turn clockwise maps cell i to cell i + 11.
  for (int i = 0; i < 44; ++i) {
    const Eigen::Vector2d p = m.BitCellCentre(i), q = m.BitCellCentre((i + 11) % 44);
    EXPECT_TRUE(Eigen::Vector2d(p.y(), -p.x()).isApprox(q)) << i;
  }
}

}  // namespace
}  // namespace svms
