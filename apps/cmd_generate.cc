// svms generate: printable artwork (SVG, PDF, PNG) and model JSON for markers and sheets.
#include <iostream>
#include <memory>
#include <set>
#include <sstream>

#include "commands.h"
#include "svms/calib/board.h"
#include "svms/codec/svms44.h"
#include "svms/marker/model_io.h"
#include "svms/print/artwork.h"

namespace svms::cli {
namespace {

struct GenerateOptions {
  int id = -1;
  double size = 0;
  int inner_id = -1;
  double inner_size = 0;
  double post_height = 0;  // 0: the default (a quarter of the innermost square)
  double post_radius = 0;  // 0: the default (a twentieth of the innermost square)
  bool concave = false, no_post = false;
  bool no_label = false, annotate_bits = false;
  double dpi = 300;
  std::string out;
  // sheet
  std::string markers_file, ids, page = "A4";
  // board
  int rows = 0, cols = 0, first_id = 0;
  double gap = 0, margin_mm = 10;
};

// The model the options describe; false (message on stderr) if they are inconsistent.
bool BuildModel(const GenerateOptions& o, int id, MarkerModel* out) {
  MarkerModel m = MarkerModel::Standard(id, o.size, 0);
  if (o.inner_id >= 0) m.AddInner(o.inner_id, o.inner_size);
  const double innermost = m.inner ? m.inner->size : m.size;
  if (!o.no_post) {
    const double h = o.post_height > 0 ? o.post_height : 0.25 * innermost;
    const double r = o.post_radius > 0 ? o.post_radius : 0.05 * innermost;
    m.post = PostModel{o.concave ? -h : h, r, r};
  }
  if (Status s = m.Validate(); !s) {
    std::cerr << "svms generate: marker " << id << ": " << s.message() << "\n";
    return false;
  }
  *out = m;
  return true;
}

// "1,2,5-8" -> {1, 2, 5, 6, 7, 8}
bool ParseIds(const std::string& text, std::vector<int>* ids) {
  std::stringstream ss(text);
  std::string item;
  while (std::getline(ss, item, ',')) {
    int a = 0, b = 0;
    char dash = 0, tail = 0;
    const int n = std::sscanf(item.c_str(), "%d%c%d%c", &a, &dash, &b, &tail);
    if (n == 1) {
      b = a;
    } else if (!(n == 3 && dash == '-')) {
      return false;
    }
    if (a < 0 || b < a || b >= Svms44::kNumIds || b - a > 10000) return false;
    for (int i = a; i <= b; ++i) ids->push_back(i);
  }
  return !ids->empty();
}

void Report(const WrittenFiles& files) {
  for (const std::string& f : files) std::cout << "wrote " << f << "\n";
}

int RunGenerateMarker(const GenerateOptions& o) {
  if ((o.inner_id >= 0) != (o.inner_size > 0)) {
    std::cerr << "svms generate marker: --inner-id and --inner-size go together\n";
    return kExitBadInput;
  }
  MarkerModel m;
  if (!BuildModel(o, o.id, &m)) return kExitBadInput;
  ArtworkOptions a;
  a.dpi = o.dpi;
  a.label = !o.no_label;
  a.annotate_bits = o.annotate_bits;
  WrittenFiles written;
  const Status s = WriteMarkerArtwork(m, o.out, a, &written);
  Report(written);
  if (!s) {
    std::cerr << "svms generate marker: " << s.message() << "\n";
    return kExitFailed;
  }
  std::cout << m.Summary() << "\n";
  return kExitOk;
}

int RunGenerateSheet(const GenerateOptions& o) {
  std::vector<MarkerModel> models;
  if (!o.markers_file.empty() == !o.ids.empty()) {
    std::cerr << "svms generate sheet: give either --markers FILE or --ids LIST (with --size)\n";
    return kExitBadInput;
  }
  if (!o.markers_file.empty()) {
    ModelFile f;
    if (Status s = ReadModelFile(o.markers_file, &f); !s) {
      std::cerr << "svms generate sheet: " << s.message() << "\n";
      return kExitBadInput;
    }
    models = f.markers;
  } else {
    std::vector<int> ids;
    if (!ParseIds(o.ids, &ids)) {
      std::cerr << "svms generate sheet: --ids \"" << o.ids
                << "\": expected a list like 1,2,5-8 of IDs in [0, 32767]\n";
      return kExitBadInput;
    }
    if (!(o.size > 0)) {
      std::cerr << "svms generate sheet: --ids needs --size (metres)\n";
      return kExitBadInput;
    }
    std::set<int> seen;
    for (int id : ids) {
      if (!seen.insert(id).second) {
        std::cerr << "svms generate sheet: --ids: ID " << id << " appears twice\n";
        return kExitBadInput;
      }
      MarkerModel m;
      if (!BuildModel(o, id, &m)) return kExitBadInput;
      models.push_back(m);
    }
  }
  SheetOptions so;
  so.dpi = o.dpi;
  so.label = !o.no_label;
  if (Status s = PageSpec::Parse(o.page, &so.page); !s) {
    std::cerr << "svms generate sheet: " << s.message() << "\n";
    return kExitBadInput;
  }
  WrittenFiles written;
  const Status s = WriteSheet(models, o.out, so, &written);
  Report(written);
  if (!s) {
    std::cerr << "svms generate sheet: " << s.message() << "\n";
    return kExitFailed;
  }
  std::cout << models.size() << " markers on page " << so.page.name << "\n";
  return kExitOk;
}

int RunGenerateBoard(const GenerateOptions& o) {
  const BoardSpec spec{o.rows, o.cols, o.size, o.gap, o.first_id};
  if (Status s = spec.Validate(); !s) {
    std::cerr << "svms generate board: " << s.message() << "\n";
    return kExitBadInput;
  }
  const Layout layout = MakeBoardLayout(spec);
  ArtworkOptions a;
  a.dpi = o.dpi;
  a.label = !o.no_label;
  WrittenFiles written;
  const Status s = WriteLayoutArtwork(layout, o.out, a, o.margin_mm, &written);
  Report(written);
  if (!s) {
    std::cerr << "svms generate board: " << s.message() << "\n";
    return kExitFailed;
  }
  std::cout << layout.Summary() << "\n";
  return kExitOk;
}

void AddMarkerShapeOptions(CLI::App* cmd, GenerateOptions& o) {
  cmd->add_option(
         "--post-height", o.post_height,
         "Post height (or well depth) in metres [default: a quarter of the innermost square]")
      ->check(CLI::PositiveNumber);
  cmd->add_option("--post-radius", o.post_radius,
                  "Post (or well) radius in metres [default: a twentieth of the innermost square]")
      ->check(CLI::PositiveNumber);
  cmd->add_flag("--concave", o.concave, "A concave well with a white bottom instead of a post");
  cmd->add_flag("--no-post", o.no_post, "A flat marker (e.g. for calibration boards)");
  cmd->add_option("--dpi", o.dpi, "PNG resolution")
      ->check(CLI::Range(10.0, 2400.0))
      ->capture_default_str();
  cmd->add_flag("--no-label", o.no_label, "Leave out the printed family/ID/size line");
}

}  // namespace

void AddGenerateCommands(CLI::App& app, int* exit_code) {
  CLI::App* gen = app.add_subcommand("generate", "Printable marker artwork and model files");
  gen->require_subcommand(1);
  auto o = std::make_shared<GenerateOptions>();

  auto* marker =
      gen->add_subcommand("marker", "One marker: SVG and PDF at exact scale, PNG, model JSON");
  marker->add_option("--id", o->id, "svms44 ID")
      ->required()
      ->check(CLI::Range(0, Svms44::kNumIds - 1));
  marker->add_option("--size", o->size, "Side of the black square, metres")
      ->required()
      ->check(CLI::PositiveNumber);
  marker->add_option("--inner-id", o->inner_id, "ID of a nested inner marker (dual marker)")
      ->check(CLI::Range(0, Svms44::kNumIds - 1));
  marker
      ->add_option("--inner-size", o->inner_size, "Side of the inner marker's black square, metres")
      ->check(CLI::PositiveNumber);
  AddMarkerShapeOptions(marker, *o);
  marker->add_flag("--annotate-bits", o->annotate_bits,
                   "Print each cell's bit index (documentation)");
  marker
      ->add_option("--out", o->out, "Output base name: writes OUT.svg, OUT.pdf, OUT.png, OUT.json")
      ->required();
  marker->footer(
      "The SVG is in millimetres and the PDF in points, both at exact physical scale: print at 100 "
      "%.\n"
      "Examples:\n"
      "  svms generate marker --id 17 --size 0.2 --out m17\n"
      "  svms generate marker --id 3 --size 0.432 --inner-id 4 --inner-size 0.108 --out dual\n"
      "  svms generate marker --id 9 --size 0.1 --concave --post-height 0.02 --out well");
  marker->callback([o, exit_code] { *exit_code = RunGenerateMarker(*o); });

  auto* sheet = gen->add_subcommand(
      "sheet", "Several markers on pages with cut marks, labels, drill crosses");
  sheet->add_option("--markers", o->markers_file,
                    "Models to lay out (svms.marker, svms.markers or svms.layout)");
  sheet->add_option("--ids", o->ids, "IDs to generate, e.g. 0-5,9 (with --size)");
  sheet->add_option("--size", o->size, "Side of the black squares for --ids, metres")
      ->check(CLI::PositiveNumber);
  AddMarkerShapeOptions(sheet, *o);
  sheet->add_option("--page", o->page, "A4, A3, Letter, or WxH in millimetres")
      ->capture_default_str();
  sheet
      ->add_option("--out", o->out,
                   "Output base name: OUT.pdf (all pages), OUT[-N].svg/png, OUT.json")
      ->required();
  sheet->footer(
      "Examples:\n"
      "  svms generate sheet --ids 0-5 --size 0.05 --page A4 --out sheet\n"
      "  svms generate sheet --markers layout.json --page 600x400 --out mockup-markers");
  sheet->callback([o, exit_code] { *exit_code = RunGenerateSheet(*o); });

  auto* board = gen->add_subcommand(
      "board", "A calibration board: a grid of flat markers (SVG/PDF/PNG) and its layout JSON");
  board->add_option("--rows", o->rows, "Markers down")->required()->check(CLI::Range(1, 1000));
  board->add_option("--cols", o->cols, "Markers across")->required()->check(CLI::Range(1, 1000));
  board->add_option("--size", o->size, "Side of each black square, metres")
      ->required()
      ->check(CLI::PositiveNumber);
  board->add_option("--gap", o->gap, "White space between neighbouring markers, metres")
      ->required()
      ->check(CLI::NonNegativeNumber);
  board->add_option("--first-id", o->first_id, "ID of the top-left marker (row by row after it)")
      ->required()
      ->check(CLI::Range(0, Svms44::kNumIds - 1));
  board->add_option("--margin", o->margin_mm, "White margin around the markers, millimetres")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  board->add_option("--dpi", o->dpi, "PNG resolution")
      ->check(CLI::Range(10.0, 2400.0))
      ->capture_default_str();
  board->add_flag("--no-label", o->no_label, "Leave out the caption line");
  board
      ->add_option("--out", o->out,
                   "Output base name: writes OUT.svg, OUT.pdf, OUT.png and OUT.json (the layout)")
      ->required();
  board->footer(
      "The board frame: origin at the grid centre, x right, y up as printed; pitch = 2 * size + "
      "gap (a marker's ring is twice its square). Print at 100 %.\n"
      "Examples:\n"
      "  svms generate board --rows 5 --cols 6 --size 0.06 --gap 0.015 --first-id 100 --out board\n"
      "  svms calibrate 'images/*.png' --board board.json --out cam.cameramodel");
  board->callback([o, exit_code] { *exit_code = RunGenerateBoard(*o); });
}

}  // namespace svms::cli
