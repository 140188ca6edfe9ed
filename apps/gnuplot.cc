#include "gnuplot.h"

#include <cstdlib>
#include <fstream>

namespace svms::cli {

Status Gnuplot(const std::string& dir, const std::string& name, const std::string& body,
               const std::string& size) {
  const std::string script = dir + "/" + name + ".gp";
  {
    std::ofstream f(script);
    f << "set terminal pngcairo size " << size << " font 'DejaVu Sans,10'\nset output '" << name
      << ".png'\n"
      << body << "\nset terminal svg size " << size << " font 'DejaVu Sans,10'\nset output '"
      << name << ".svg'\n"
      << body << "\n";
    if (!f) return Status::Error(script + ": cannot write");
  }
  const std::string cmd = "cd '" + dir + "' && gnuplot '" + name + ".gp' 2>'" + name + ".gp.log'";
  if (std::system(cmd.c_str()) != 0)
    return Status::Error(script + ": gnuplot failed (see " + script + ".log)");
  return Status::Ok();
}

}  // namespace svms::cli
