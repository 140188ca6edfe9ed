#include "svms/bench/stored_frames.h"

#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "svms/pipelines/exit_codes.h"

namespace svms {

namespace fs = std::filesystem;

Status ReadStoredPhotometry(const std::string& truth_path, std::optional<PhotometricModel>* model,
                            PhotometryOptions* options) {
  model->reset();
  *options = PhotometryOptions{};
  nlohmann::json doc;
  try {
    std::ifstream in(truth_path);
    doc = nlohmann::json::parse(in);
    if (!doc.contains("photometry")) return Status::Ok();
    const nlohmann::json& ph = doc.at("photometry");
    options->response = ph.value("response", std::string("linear"));
    options->bayer = ph.value("bayer", std::string());
    options->black_level = ph.value("black_level", 0.0);
    options->white_level = ph.value("white_level", 255.0);
    const double full = ph.value("bits", 8) > 8 ? 65535.0 : 255.0;
    nlohmann::json text = {{"type", "svms.photometric"},
                           {"response", options->response},
                           {"black_level", *options->black_level},
                           {"white_level", *options->white_level}};
    if (!options->bayer.empty()) text["bayer"] = options->bayer;
    PhotometricModel m;
    if (Status s = ParsePhotometricJson(text.dump(), truth_path + ": photometry", &m); !s) return s;
    if (m.response.kind() != Response::Kind::kLinear || m.black_level != 0 ||
        m.white_level != full || m.bayer != BayerPattern::kNone)
      *model = m;
  } catch (const std::exception& e) {
    return Status::Error(truth_path + ": photometry: expected the renderer's block (response, " +
                         "black_level, white_level, bits, bayer): " + e.what());
  }
  return Status::Ok();
}

int ReadStoredImages(const std::string& D, const std::vector<std::pair<std::string, Pose>>& truth,
                     std::vector<cv::Mat>* images) {
  const std::string truth_path = D + "/truth.json";
  std::map<std::string, std::string> file_of;
  try {
    std::ifstream in(truth_path);
    const nlohmann::json doc = nlohmann::json::parse(in);
    for (const auto& v : doc.value("views", nlohmann::json::array()))
      if (v.contains("image") && v["image"].is_string()) {
        const std::string file = v["image"];
        file_of[fs::path(file).stem().string()] = file;
      }
  } catch (const std::exception& e) {
    std::cerr << "svms bench: " << truth_path << ": views: " << e.what() << "\n";
    return kExitBadInput;
  }
  for (const auto& [name, pose] : truth) {
    const auto it = file_of.find(name);
    const std::string path = D + "/" + (it == file_of.end() ? name + ".png" : it->second);
    images->push_back(cv::imread(path, cv::IMREAD_UNCHANGED));
    if (images->back().empty()) {
      std::cerr << "svms bench: " << path << ": cannot read\n";
      return kExitBadInput;
    }
  }
  return kExitOk;
}

}  // namespace svms
