#include "gnuplot.h"

#include <cstdio>
#include <fstream>

namespace svms::cli {
namespace {

Status RunGnuplot(const std::string& program, const std::string& what) {
  FILE* pipe = popen("gnuplot 2>&1", "w");
  if (!pipe) return Status::Error(what + ": cannot start gnuplot (install gnuplot-nox)");
  std::fwrite(program.data(), 1, program.size(), pipe);
  const int rc = pclose(pipe);
  if (rc != 0) return Status::Error(what + ": gnuplot failed (exit " + std::to_string(rc) + ")");
  return Status::Ok();
}

}  // namespace

Status PlotPngSvg(const std::string& script, const std::string& base) {
  {
    std::ofstream gp(base + ".gp");
    gp << script;
    if (!gp) return Status::Error(base + ".gp: cannot write");
  }
  const std::string png =
      "set terminal pngcairo size 1000,650 font 'DejaVu Sans,11'\nset output '" + base + ".png'\n" +
      script + "\nunset output\n";
  if (Status s = RunGnuplot(png, base + ".png"); !s) return s;
  const std::string svg =
      "set terminal svg size 1000,650 dynamic font 'DejaVu Sans,11'\nset output '" + base +
      ".svg'\n" + script + "\nunset output\n";
  return RunGnuplot(svg, base + ".svg");
}

}  // namespace svms::cli
