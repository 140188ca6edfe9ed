#include "svms/base/file_io.h"

#include <gtest/gtest.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <unistd.h>

#include <csignal>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "svms/base/memory_limit.h"
#include "svms_testing/scratch_dir.h"

namespace svms {
namespace {

namespace fs = std::filesystem;

std::string Slurp(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  std::stringstream ss;
  ss << f.rdbuf();
  return ss.str();
}

// The names in `dir` (no temporaries may be left behind).
std::vector<std::string> Names(const fs::path& dir) {
  std::vector<std::string> out;
  for (const auto& e : fs::directory_iterator(dir)) out.push_back(e.path().filename().string());
  std::sort(out.begin(), out.end());
  return out;
}

// A file-size limit for the scope (SIGXFSZ ignored, so write(2) reports EFBIG instead of the
// signal killing the test). Works for root too: RLIMIT_FSIZE binds every user.
class FileSizeLimit {
 public:
  explicit FileSizeLimit(rlim_t bytes) {
    previous_handler_ = std::signal(SIGXFSZ, SIG_IGN);
    getrlimit(RLIMIT_FSIZE, &previous_);
    struct rlimit rl = previous_;
    rl.rlim_cur = bytes;
    setrlimit(RLIMIT_FSIZE, &rl);
  }
  ~FileSizeLimit() {
    setrlimit(RLIMIT_FSIZE, &previous_);
    std::signal(SIGXFSZ, previous_handler_);
  }

 private:
  struct rlimit previous_;
  void (*previous_handler_)(int);
};

TEST(WriteFileAtomically, CreatesAndReplaces) {
  svms_testing::ScratchDir dir("svms_file_io_test");
  const std::string f = dir.File("a.json");
  ASSERT_TRUE(WriteFileAtomically(f, "first").ok());
  EXPECT_EQ(Slurp(f), "first");
  ASSERT_TRUE(WriteFileAtomically(f, "second, longer").ok());
  EXPECT_EQ(Slurp(f), "second, longer");
  ASSERT_TRUE(WriteFileAtomically(f, "").ok());
  EXPECT_EQ(Slurp(f), "");
  EXPECT_EQ(Names(dir.path()), std::vector<std::string>{"a.json"});
}

TEST(WriteFileAtomically, AFailedWriteLeavesTheEarlierFileAndNoTemporary) {
  svms_testing::ScratchDir dir("svms_file_io_test");
  const std::string f = dir.File("layout.json");
  const std::string good = std::string(1000, 'g');
  ASSERT_TRUE(WriteFileAtomically(f, good).ok());
  {
    FileSizeLimit limit(4096);
    const Status s = WriteFileAtomically(f, std::string(100000, 'x'));
    ASSERT_FALSE(s.ok());
    EXPECT_NE(s.message().find(f + ": cannot write: File too large"), std::string::npos)
        << s.message();
  }
  EXPECT_EQ(Slurp(f), good);
  EXPECT_EQ(Names(dir.path()), std::vector<std::string>{"layout.json"});
}

TEST(WriteFileAtomically, KeepsPermissionsAndFollowsSymlinks) {
  svms_testing::ScratchDir dir("svms_file_io_test");
  const std::string f = dir.File("cam.cameramodel");
  ASSERT_TRUE(WriteFileAtomically(f, "v1").ok());
  ASSERT_EQ(::chmod(f.c_str(), 0640), 0);
  ASSERT_TRUE(WriteFileAtomically(f, "v2").ok());
  struct stat st;
  ASSERT_EQ(::stat(f.c_str(), &st), 0);
  EXPECT_EQ(st.st_mode & 0777, 0640u);
  const std::string link = dir.File("link.cameramodel");
  fs::create_symlink(f, link);
  ASSERT_TRUE(WriteFileAtomically(link, "v3").ok());
  EXPECT_TRUE(fs::is_symlink(link));
  EXPECT_EQ(Slurp(f), "v3");
}

TEST(WriteFileAtomically, ErrorsNameThePathAndTheReason) {
  svms_testing::ScratchDir dir("svms_file_io_test");
  Status s = WriteFileAtomically(dir.File("missing/a.json"), "x");
  EXPECT_EQ(s.message(), dir.File("missing/a.json") + ": cannot write: No such file or directory");
  fs::create_directory(dir.File("d"));
  s = WriteFileAtomically(dir.File("d"), "x");
  EXPECT_EQ(s.message(), dir.File("d") + ": cannot write: it is a directory; expected a file name");
  // A path through a file (what an unwritable directory looks like to root, too).
  ASSERT_TRUE(WriteFileAtomically(dir.File("f"), "x").ok());
  s = WriteFileAtomically(dir.File("f/a.json"), "x");
  EXPECT_EQ(s.message(), dir.File("f/a.json") + ": cannot write: Not a directory");
  EXPECT_FALSE(WriteFileAtomically("", "x").ok());
}

TEST(AtomicFileSet, AllOrNothing) {
  svms_testing::ScratchDir dir("svms_file_io_test");
  const std::string model = dir.File("cam.cameramodel"), sidecar = model + ".covariance.json";
  ASSERT_TRUE(WriteFileAtomically(model, "old model").ok());
  ASSERT_TRUE(WriteFileAtomically(sidecar, "old sidecar").ok());
  {
    // The second file does not fit: neither is replaced.
    FileSizeLimit limit(4096);
    AtomicFileSet set;
    set.Add(model, "new model");
    set.Add(sidecar, std::string(100000, 'c'));
    EXPECT_FALSE(set.Commit().ok());
    EXPECT_TRUE(set.empty());
  }
  EXPECT_EQ(Slurp(model), "old model");
  EXPECT_EQ(Slurp(sidecar), "old sidecar");
  EXPECT_EQ(Names(dir.path()),
            (std::vector<std::string>{"cam.cameramodel", "cam.cameramodel.covariance.json"}));
  AtomicFileSet set;
  set.Add(model, "x");
  set.Add(sidecar, "new sidecar");
  set.Add(model, "new model");  // replaces the first Add
  EXPECT_EQ(set.paths(), (std::vector<std::string>{model, sidecar}));
  ASSERT_TRUE(set.Commit().ok());
  EXPECT_EQ(Slurp(model), "new model");
  EXPECT_EQ(Slurp(sidecar), "new sidecar");
}

TEST(ReadTextFile, RefusesFifosDirectoriesAndEndlessFiles) {
  svms_testing::ScratchDir dir("svms_file_io_test");
  const std::string fifo = dir.File("pipe");
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  std::string text;
  Status s = ReadTextFile(fifo, &text);
  EXPECT_NE(s.message().find(fifo + ": is a FIFO; expected a regular file"), std::string::npos)
      << s.message();
  s = ReadTextFile(dir.path().string(), &text);
  EXPECT_EQ(s.message(), dir.path().string() + ": is a directory; expected a file");
  s = ReadTextFile("/dev/zero", &text);
  EXPECT_EQ(s.message(), "/dev/zero: more than 64 MiB; expected a file of a sensible size");
  ASSERT_TRUE(WriteFileAtomically(dir.File("t"), "abc").ok());
  ASSERT_TRUE(ReadTextFile(dir.File("t"), &text).ok());
  EXPECT_EQ(text, "abc");
  EXPECT_EQ(ReadTextFile(dir.File("nope"), &text).message(),
            dir.File("nope") + ": cannot open for reading: No such file or directory");
}

TEST(SameFile, SeesLinksAndOtherSpellings) {
  svms_testing::ScratchDir dir("svms_file_io_test");
  ASSERT_TRUE(WriteFileAtomically(dir.File("a.png"), "x").ok());
  fs::create_hard_link(dir.File("a.png"), dir.File("b.png"));
  EXPECT_TRUE(SameFile(dir.File("a.png"), dir.File("b.png")));
  EXPECT_TRUE(SameFile(dir.File("a.png"), dir.path().string() + "/./a.png"));
  EXPECT_FALSE(SameFile(dir.File("a.png"), dir.File("c.png")));
}

TEST(MemoryLimit, TheEnvironmentSetsItAndRequestsBeyondItAreRefused) {
  setenv("SVMS_MEMORY_LIMIT", "2G", 1);
  std::string source;
  EXPECT_EQ(MemoryLimitBytes(&source), uint64_t{2} << 30);
  EXPECT_EQ(source, "SVMS_MEMORY_LIMIT=2G");
  EXPECT_TRUE(CheckMemory("a render", 1.9 * (1 << 30)).ok());
  EXPECT_EQ(CheckMemory("a render", 3.0 * (1 << 30)).message(),
            "a render needs about 3.0 GiB of memory, more than the limit of 2.0 GiB "
            "(SVMS_MEMORY_LIMIT=2G); expected a smaller request");
  unsetenv("SVMS_MEMORY_LIMIT");
  EXPECT_GT(MemoryLimitBytes(&source), uint64_t{1} << 28);
  EXPECT_NE(source.find("3/4 of this machine's"), std::string::npos) << source;
}

}  // namespace
}  // namespace svms
