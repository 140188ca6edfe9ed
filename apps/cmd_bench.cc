// svms bench: the benchmarks, run by the svms-bench program beside svms (svms_bench_main.cc).
// svms itself links neither the benchmark library nor the peers it compares with (AprilTag,
// ArUco); an installation without the benchmarks says so.
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <iostream>
#include <vector>

#include "commands.h"

namespace svms::cli {

int RunBenchProgram(int argc, char** argv) {
  namespace fs = std::filesystem;
  std::error_code ec;
  const fs::path self = fs::read_symlink("/proc/self/exe", ec);
  const fs::path program = self.parent_path() / "svms-bench";
  if (ec || ::access(program.c_str(), X_OK) != 0) {
    std::cerr << "svms bench: " << (ec ? std::string("svms-bench") : program.string())
              << " not found beside svms: the benchmarks are not part of this installation "
                 "(build them from the source tree: build/bin/svms bench)\n";
    return kExitBadInput;
  }
  std::vector<char*> args;
  args.push_back(const_cast<char*>(program.c_str()));
  for (int i = 0; i < argc; ++i) args.push_back(argv[i]);
  args.push_back(nullptr);
  execv(program.c_str(), args.data());
  std::cerr << "svms bench: " << program.string() << ": cannot run: " << std::strerror(errno)
            << "\n";
  return kExitFailed;
}

void AddBenchCommands(CLI::App& app, int* exit_code) {
  // Listed in `svms --help`; main() hands `svms bench ...` to RunBenchProgram before parsing,
  // and the callback does the same for a command line that reaches it.
  CLI::App* bench = app.add_subcommand(
      "bench", "Measure detection, accuracy and speed on simulated datasets against truth");
  bench->prefix_command();
  bench->allow_extras();
  bench->set_help_flag();
  bench->callback([bench, exit_code] {
    std::vector<std::string> rest = bench->remaining();
    std::vector<char*> argv;
    for (std::string& a : rest) argv.push_back(a.data());
    *exit_code = RunBenchProgram(static_cast<int>(argv.size()), argv.data());
  });
}

}  // namespace svms::cli
