// Running another program (gnuplot, mrcal's tools, Python) without a shell: the arguments go
// to execvp as they are, so no file name can be misread as shell syntax (a report directory
// called "rep o'brien" is just a name), and the one place that starts programs is here.
#pragma once

#include <string>
#include <vector>

namespace svms {

struct RunProgramOptions {
  std::string cwd;          // "" = the current directory
  std::string stdin_text;   // written to the program's standard input (then closed)
  std::string stdout_path;  // "" = inherited; else the file its standard output goes to
  std::string stderr_path;  // "" = inherited; else the file its standard error goes to
};

// Runs argv[0] (looked up in PATH) with `argv` and waits for it. Returns its exit code, 127
// when it could not be started (not installed), 128 + N when killed by signal N. The caller
// ignores SIGPIPE (as `svms` and `svms-bench` do), so that a program that exits without reading
// its standard input is an error of the write, not the death of the caller.
int RunProgram(const std::vector<std::string>& argv, const RunProgramOptions& options = {});

// Two new empty files in the temporary directory ($TMPDIR or /tmp) for a program's result and
// its standard error, removed when this goes out of scope; a path is "" when it could not be
// made.
struct ProgramOutputFiles {
  ProgramOutputFiles(const char* out_name, const char* err_name);
  ~ProgramOutputFiles();
  ProgramOutputFiles(const ProgramOutputFiles&) = delete;
  ProgramOutputFiles& operator=(const ProgramOutputFiles&) = delete;
  std::string out, err;
};

// The last non-empty line of a text (a program's one-line diagnosis), without its newline.
std::string LastLine(const std::string& text);

}  // namespace svms
