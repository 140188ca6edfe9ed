#include "svms/pipelines/gnuplot.h"

#include <filesystem>
#include <sstream>

#include "svms/pipelines/run_program.h"

namespace svms {

Status Gnuplot(const std::string& dir, const std::string& name, const std::string& body,
               const std::string& size, AtomicFileSet* into) {
  namespace fs = std::filesystem;
  const fs::path d(dir);
  // gnuplot draws into temporaries (its own output files are not written atomically); they
  // are renamed into place, or handed to `into`, only when it succeeds.
  const std::string tmp_png = "." + name + ".png.svms-plot",
                    tmp_svg = "." + name + ".svg.svms-plot",
                    tmp_log = "." + name + ".gp.log.svms-plot";
  // The script kept beside the pictures names them (to edit and run again); the one gnuplot
  // runs, on its standard input, draws into the temporaries.
  auto script_for = [&](const std::string& png, const std::string& svg) {
    return "set terminal pngcairo size " + size + " font 'DejaVu Sans,10'\nset output '" + png +
           "'\n" + body + "\nset terminal svg size " + size +
           " font 'DejaVu Sans,10'\nset output '" + svg + "'\n" + body + "\nset output\n";
  };
  const std::string text = script_for(name + ".png", name + ".svg");
  const std::string script = (d / (name + ".gp")).string();
  if (Status s = into ? into->Add(script, text) : WriteFileAtomically(script, text); !s) return s;
  // Data files of the same group are not at their names until the group is committed: gnuplot
  // reads them from their temporaries (each 'NAME' in the script that is a file of the group in
  // this directory; the directories compared as files, so "rep/" and "rep" are one).
  std::string run_text = script_for(tmp_png, tmp_svg);
  if (into) {
    for (const std::string& path : into->paths()) {
      std::error_code ec;
      const fs::path parent = fs::path(path).parent_path();
      if (!fs::equivalent(parent.empty() ? fs::path(".") : parent, d.empty() ? fs::path(".") : d,
                          ec))
        continue;
      const std::string from = "'" + fs::path(path).filename().string() + "'";
      const std::string to = "'" + fs::path(into->temporary(path)).filename().string() + "'";
      for (size_t at = 0; (at = run_text.find(from, at)) != std::string::npos; at += to.size())
        run_text.replace(at, from.size(), to);
    }
  }
  RunProgramOptions ro;
  ro.cwd = dir;
  ro.stdin_text = run_text;
  ro.stdout_path = ro.stderr_path = tmp_log;
  const int rc = RunProgram({"gnuplot"}, ro);
  std::error_code ec;
  if (rc != 0) {
    // What went wrong goes into the message (the last line gnuplot printed), not into a file
    // that would replace an earlier log.
    std::string log, last;
    if (ReadFileBytes((d / tmp_log).string(), 1 << 20, &log).ok()) {
      std::istringstream lines(log);
      for (std::string l; std::getline(lines, l);)
        if (l.find_first_not_of(" \t^") != std::string::npos) last = l;
    }
    for (const std::string& f : {tmp_png, tmp_svg, tmp_log}) fs::remove(d / f, ec);
    return Status::Error(
        script + (rc == 127 ? ": gnuplot is not installed (apt-get install "
                              "gnuplot-nox)"
                            : ": gnuplot failed" + (last.empty() ? std::string() : ": " + last)));
  }
  for (const auto& [from, to] :
       {std::pair{tmp_png, name + ".png"}, std::pair{tmp_svg, name + ".svg"},
        std::pair{tmp_log, name + ".gp.log"}}) {
    if (into) {
      into->Adopt((d / to).string(), (d / from).string());
      continue;
    }
    fs::rename(d / from, d / to, ec);
    if (ec) {
      fs::remove(d / from, ec);
      return Status::Error((d / to).string() + ": cannot write: " + ec.message());
    }
  }
  return Status::Ok();
}

}  // namespace svms
