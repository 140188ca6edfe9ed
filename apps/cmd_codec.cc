// svms codec: the svms44 code -- statistics, encode, decode, and reading artwork PNGs.
#include <cstdio>
#include <iostream>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <thread>

#include "commands.h"
#include "svms/codec/codec_stats.h"
#include "svms/codec/svms44.h"
#include "svms/detect/bit_sampler.h"
#include "svms/marker/model_io.h"
#include "svms/print/artwork.h"

namespace svms::cli {
namespace {

int RunStats(bool as_json, int64_t samples, uint64_t seed, int threads) {
  std::cerr << "svms codec stats: measuring all ID pairs and " << samples << " random words on "
            << threads << " threads...\n";
  const CodecStats s = MeasureCodecStats(samples, seed, threads);
  nlohmann::json pairs;
  for (const auto& [d, n] : s.rotation_distance_pairs) pairs[std::to_string(d)] = n;
  nlohmann::json j = {
      {"family", Svms44::kFamily},
      {"bits", s.bits},
      {"ids", s.ids},
      {"code_min_distance", s.code_min_distance},
      {"min_distance", s.min_distance},
      {"rotation_min_distance", s.rotation_min_distance},
      {"rotation_distance_pairs", pairs},
      {"strong_ids", kSvms44PhaseFirstId[1]},
      {"strong_rotation_min_distance", kSvms44PhaseDistance[0]},
      {"false_accept", s.false_accept},
      {"false_accept_hits", s.false_accept_hits},
      {"false_accept_exact", s.false_accept_exact},
      {"false_accept_samples", s.false_accept_samples},
      {"ambiguous_rate", samples ? double(s.ambiguous_hits) / samples : 0.0},
      {"seed", seed},
  };
  if (as_json) {
    std::cout << j.dump() << "\n";
    return kExitOk;
  }
  std::printf("family                 %s\n", Svms44::kFamily);
  std::printf("bits                   %d (BCH(63,36) shortened to (44,17))\n", s.bits);
  std::printf("ids                    %d\n", s.ids);
  std::printf("code minimum distance  %d\n", s.code_min_distance);
  std::printf("ID minimum distance    %d (same orientation)\n", s.min_distance);
  std::printf("rotation-aware min     %d (IDs 0-%d: %d)\n", s.rotation_min_distance,
              kSvms44PhaseFirstId[1] - 1, kSvms44PhaseDistance[0]);
  std::printf("false accept, random 44-bit word, by correction limit (%lld samples):\n",
              static_cast<long long>(samples));
  for (int k = 0; k <= 5; ++k) {
    std::printf("  limit %d: measured %.3e (%lld hits)", k, s.false_accept[k],
                static_cast<long long>(s.false_accept_hits[k]));
    if (s.false_accept_exact[k] >= 0) std::printf(", exact %.3e", s.false_accept_exact[k]);
    std::printf("\n");
  }
  return kExitOk;
}

bool ParseWord(const std::string& text, uint64_t* word) {
  if (Svms44::FromBitString(text, word)) return true;
  if (text.size() > 2 && (text[0] == '0') && (text[1] == 'x' || text[1] == 'X')) {
    char* end = nullptr;
    const unsigned long long v = std::strtoull(text.c_str() + 2, &end, 16);
    if (*end == 0 && v < (1ULL << 44)) {
      *word = v;
      return true;
    }
  }
  return false;
}

nlohmann::json MatchJson(const CodeMatch& m) {
  const char* verdict = m.verdict == CodeMatch::Verdict::kAccepted    ? "accepted"
                        : m.verdict == CodeMatch::Verdict::kAmbiguous ? "ambiguous"
                                                                      : "no_codeword";
  nlohmann::json j = {{"verdict", verdict}};
  if (m.accepted()) {
    j["id"] = m.id;
    j["rotation"] = m.rotation;
    j["bit_errors"] = m.bit_errors;
  }
  j["runner_up_errors"] =
      m.runner_up_errors >= 0 ? nlohmann::json(m.runner_up_errors) : nlohmann::json();
  return j;
}

int RunDecode(const std::string& text, int limit, int id_count, bool as_json) {
  uint64_t word = 0;
  if (!ParseWord(text, &word)) {
    std::cerr
        << "svms codec decode: \"" << text
        << "\": expected 44 characters of 0/1 (bit 0 first) or 0x followed by hex below 2^44\n";
    return kExitBadInput;
  }
  const CodeMatch m = Svms44::Decode(word, limit, id_count);
  if (as_json) {
    std::cout << MatchJson(m).dump() << "\n";
  } else if (m.accepted()) {
    std::cout << "id " << m.id << " rotation " << m.rotation << " bit_errors " << m.bit_errors
              << "\n";
  } else {
    std::cout << (m.verdict == CodeMatch::Verdict::kAmbiguous ? "ambiguous" : "no codeword")
              << " within " << limit << " corrections\n";
  }
  return m.accepted() ? kExitOk : kExitFailed;
}

// Reads a single-marker artwork PNG: samples the cells where the model puts them (marker centre
// at the image centre, dpi / 0.0254 pixels per metre) and decodes, for the marker and its
// nested marker.
int RunRead(const std::string& png, const std::string& model_path, double dpi, bool as_json) {
  ModelFile file;
  if (Status s = ReadModelFile(model_path, &file); !s) {
    std::cerr << "svms codec read: " << s.message() << "\n";
    return kExitBadInput;
  }
  if (file.kind != ModelFile::Kind::kMarker) {
    std::cerr << "svms codec read: " << model_path
              << ": expected a single marker model (type svms.marker)\n";
    return kExitBadInput;
  }
  const cv::Mat img = cv::imread(png, cv::IMREAD_GRAYSCALE);
  if (img.empty()) {
    std::cerr << "svms codec read: " << png << ": cannot read as an image\n";
    return kExitBadInput;
  }
  const Eigen::Matrix3d H = ArtworkPixelFromPlane(img.cols, img.rows, dpi);
  std::vector<MarkerModel> models{file.markers[0]};
  if (auto inner = file.markers[0].InnerModel()) models.push_back(*inner);
  int rc = kExitOk;
  nlohmann::json out = nlohmann::json::array();
  for (const MarkerModel& m : models) {
    const BitReading r = SampleBits(img, H, m);
    const CodeMatch match = Svms44::Decode(r.word, Svms44::kMaxCorrections);
    const bool right = match.accepted() && match.id == m.id && match.rotation == 0;
    if (!right) rc = kExitFailed;
    nlohmann::json j = MatchJson(match);
    j["expected_id"] = m.id;
    j["bits"] = Svms44::ToBitString(r.word);
    j["weakest_margin"] = r.weakest();
    j["samples_outside"] = r.samples_outside;
    out.push_back(j);
    if (!as_json) {
      std::printf("%s: expected ID %d, read %s%s (bit errors %d, weakest margin %.2f)\n",
                  png.c_str(), m.id,
                  match.accepted() ? ("ID " + std::to_string(match.id)).c_str() : "nothing",
                  right ? "" : "  <-- MISMATCH", match.bit_errors, r.weakest());
    }
  }
  if (as_json) std::cout << out.dump() << "\n";
  return rc;
}

struct CodecOptions {
  bool json = false;
  int64_t samples = int64_t{1} << 22;
  uint64_t seed = 1;
  int threads = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  int id = 0;
  bool grid = false;
  std::string bits, png, model;
  int limit = Svms44::kMaxCorrections;
  double dpi = 300;
  int id_count = Svms44::kNumIds;
};

void PrintGrid(int id) {
  const uint64_t w = Svms44::Codeword(id);
  const MarkerModel m = MarkerModel::Standard(id, 12, 0);  // cell size 2: easy rounding
  std::string g[12];
  for (int r = 0; r < 12; ++r) {
    g[r].assign(12, '.');
    for (int c = 0; c < 12; ++c)
      if (r >= 3 && r <= 8 && c >= 3 && c <= 8) g[r][c] = '#';  // the black square
  }
  for (int i = 0; i < Svms44::kBits; ++i) {
    const Eigen::Vector2d c = m.BitCellCentre(i);
    const int col = static_cast<int>(std::lround(c.x() / 2 + 5.5));
    const int row = static_cast<int>(std::lround(5.5 - c.y() / 2));
    g[row][col] = ((w >> i) & 1) ? '.' : '#';
  }
  for (const auto& row : g) std::cout << row << "\n";
}

}  // namespace

void AddCodecCommands(CLI::App& app, int* exit_code) {
  CLI::App* codec =
      app.add_subcommand("codec", "The svms44 code: statistics, encode, decode, read artwork");
  codec->require_subcommand(1);
  auto o = std::make_shared<CodecOptions>();

  auto* stats =
      codec->add_subcommand("stats", "Measure the family: distances and false-accept rates");
  stats->add_flag("--json", o->json, "One JSON object on stdout");
  stats->add_option("--samples", o->samples, "Random words for the false-accept rates")
      ->check(CLI::Range(int64_t{0}, int64_t{1} << 34))
      ->capture_default_str();
  stats->add_option("--seed", o->seed, "Seed of the random words")
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber);
  stats->add_option("--threads", o->threads, "Threads")
      ->check(CLI::Range(1, 256))
      ->capture_default_str();
  stats->footer("Examples:\n  svms codec stats\n  svms codec stats --json --samples 100000000");
  stats->callback(
      [o, exit_code] { *exit_code = RunStats(o->json, o->samples, o->seed, o->threads); });

  auto* encode =
      codec->add_subcommand("encode", "Print the 44 bits of an ID (bit 0 first; white = 1)");
  encode->add_option("ID", o->id, "svms44 ID")
      ->required()
      ->check(CLI::Range(0, Svms44::kNumIds - 1));
  encode->add_flag("--grid", o->grid, "Also draw the 12x12 marker as text (# black, . white)");
  encode->footer("Examples:\n  svms codec encode 17\n  svms codec encode 17 --grid");
  encode->callback([o, exit_code] {
    std::cout << Svms44::ToBitString(Svms44::Codeword(o->id)) << "\n";
    if (o->grid) PrintGrid(o->id);
    *exit_code = kExitOk;
  });

  auto* decode = codec->add_subcommand("decode", "Decode 44 bits: ID, rotation and corrected bits");
  decode->add_option("BITS", o->bits, "44 characters of 0/1 (bit 0 first), or 0x<hex>")->required();
  decode->add_option("--max-corrections", o->limit, "Accept at most this many flipped bits (0-5)")
      ->check(CLI::Range(0, 5))
      ->capture_default_str();
  decode
      ->add_option("--id-count", o->id_count,
                   "Decode among IDs [0, N) only; N <= " + std::to_string(Svms44::StrongIdCount()) +
                       " guarantees 5-bit correction")
      ->check(CLI::Range(1, Svms44::kNumIds))
      ->capture_default_str();
  decode->add_flag("--json", o->json, "JSON output");
  decode->footer(
      "Exit code 1 when the word does not decode.\nExamples:\n"
      "  svms codec decode $(svms codec encode 17)\n"
      "  svms codec decode 0x1a2b3c4d5e6 --max-corrections 2 --json");
  decode->callback(
      [o, exit_code] { *exit_code = RunDecode(o->bits, o->limit, o->id_count, o->json); });

  auto* read =
      codec->add_subcommand("read", "Decode the artwork PNG written by 'svms generate marker'");
  read->add_option("PNG", o->png, "The marker's PNG")->required();
  read->add_option("--model", o->model, "The marker's model JSON")->required();
  read->add_option("--dpi", o->dpi, "The PNG's resolution")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  read->add_flag("--json", o->json, "JSON output");
  read->footer(
      "Samples each bit cell where the model says it is (marker centre at the image centre)\n"
      "and decodes. Exit code 1 unless every ID reads back right.\nExamples:\n"
      "  svms generate marker --id 17 --size 0.1 --out m17 && svms codec read m17.png --model "
      "m17.json");
  read->callback([o, exit_code] { *exit_code = RunRead(o->png, o->model, o->dpi, o->json); });
}

}  // namespace svms::cli
