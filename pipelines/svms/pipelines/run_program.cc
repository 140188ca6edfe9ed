#include "svms/pipelines/run_program.h"

#include <fcntl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>

namespace svms {

int RunProgram(const std::vector<std::string>& argv, const RunProgramOptions& o) {
  if (argv.empty()) return 127;
  std::vector<char*> args;
  for (const std::string& a : argv) args.push_back(const_cast<char*>(a.c_str()));
  args.push_back(nullptr);
  int in_pipe[2] = {-1, -1};
  if (pipe2(in_pipe, O_CLOEXEC) != 0) return 127;
  const pid_t pid = fork();
  if (pid < 0) {
    close(in_pipe[0]), close(in_pipe[1]);
    return 127;
  }
  if (pid == 0) {
    // The child: only async-signal-safe calls until exec.
    if (in_pipe[0] == STDIN_FILENO)
      fcntl(STDIN_FILENO, F_SETFD, 0);  // our own stdin was closed: keep the pipe across exec
    else
      dup2(in_pipe[0], STDIN_FILENO);
    if (!o.cwd.empty() && chdir(o.cwd.c_str()) != 0) _exit(127);
    // One open file for both streams when they name the same file (two opens would write
    // over each other from offset 0).
    auto redirect = [](const std::string& path, int fd) {
      if (path.empty()) return true;
      const int f = open(path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0666);
      if (f < 0) return false;
      return dup2(f, fd) >= 0;
    };
    if (!redirect(o.stdout_path, STDOUT_FILENO)) _exit(127);
    if (!o.stderr_path.empty() && o.stderr_path == o.stdout_path) {
      if (dup2(STDOUT_FILENO, STDERR_FILENO) < 0) _exit(127);
    } else if (!redirect(o.stderr_path, STDERR_FILENO)) {
      _exit(127);
    }
    execvp(args[0], args.data());
    _exit(127);
  }
  close(in_pipe[0]);
  // A program that exits without reading its input gives EPIPE here, not SIGPIPE: the caller
  // ignores that signal (run_program.h).
  const char* p = o.stdin_text.data();
  size_t left = o.stdin_text.size();
  while (left > 0) {
    const ssize_t n = write(in_pipe[1], p, left);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) break;
    p += n, left -= static_cast<size_t>(n);
  }
  close(in_pipe[1]);
  int status = 0;
  while (waitpid(pid, &status, 0) < 0)
    if (errno != EINTR) return 127;
  if (WIFEXITED(status)) return WEXITSTATUS(status);
  if (WIFSIGNALED(status)) return 128 + WTERMSIG(status);
  return 127;
}

namespace {

std::string MakeTempFile(const char* what) {
  const char* dir = std::getenv("TMPDIR");
  std::string path = std::string(dir && *dir ? dir : "/tmp") + "/svms-" + what + "-XXXXXX";
  const int fd = mkstemp(path.data());
  if (fd < 0) return "";
  close(fd);
  return path;
}

}  // namespace

ProgramOutputFiles::ProgramOutputFiles(const char* out_name, const char* err_name)
    : out(MakeTempFile(out_name)), err(MakeTempFile(err_name)) {}

ProgramOutputFiles::~ProgramOutputFiles() {
  if (!out.empty()) std::remove(out.c_str());
  if (!err.empty()) std::remove(err.c_str());
}

std::string LastLine(const std::string& text) {
  const size_t end = text.find_last_not_of(" \n\r\t");
  if (end == std::string::npos) return "";
  const size_t newline = text.rfind('\n', end);
  const size_t begin = newline == std::string::npos ? 0 : newline + 1;
  return text.substr(begin, end - begin + 1);
}

}  // namespace svms
