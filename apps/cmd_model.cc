// svms model: checking marker model, marker set and layout files.
#include <iostream>
#include <memory>

#include "commands.h"
#include "svms/marker/model_io.h"

namespace svms::cli {

// Prints "FILE: summary" for each good file and the one-line error for each bad one; every
// file is checked. Exit 2 if any was bad.
int RunModelCheck(const std::vector<std::string>& files) {
  int bad = 0;
  for (const std::string& f : files) {
    ModelFile m;
    if (Status s = ReadModelFile(f, &m); !s) {
      std::cerr << s.message() << "\n";
      ++bad;
      continue;
    }
    std::cout << f << ": " << m.Summary() << "\n";
  }
  if (bad) std::cerr << "svms model check: " << bad << " of " << files.size() << " files are bad\n";
  return bad ? kExitBadInput : kExitOk;
}

void AddModelCommands(CLI::App& app, int* exit_code) {
  CLI::App* model = app.add_subcommand("model", "Marker model and layout files");
  model->require_subcommand(1);
  auto files = std::make_shared<std::vector<std::string>>();
  auto* check = model->add_subcommand("check", "Validate model, marker-set and layout files");
  check->add_option("FILE", *files, "JSON files (svms.marker, svms.markers, svms.layout)")
      ->required();
  check->footer(
      "Prints one line per file (kind, IDs, sizes); bad files get one line on stderr\n"
      "naming the file, the field and what was expected, and the exit code is 2.\n"
      "Examples:\n  svms model check m17.json\n  svms model check board.json layout.json");
  check->callback([files, exit_code] { *exit_code = RunModelCheck(*files); });
}

}  // namespace svms::cli
