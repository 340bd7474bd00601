#pragma once

#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

#include <gtest/gtest.h>

namespace fluoro_tracker {
namespace test_support {

// A fresh folder under the system temp dir, removed with everything in it on destruction.
class TempDir {
 public:
  TempDir() {
    std::string pattern = (std::filesystem::temp_directory_path() / "fluoro_test_XXXXXX").string();
    if (mkdtemp(pattern.data()) == nullptr) throw std::runtime_error("mkdtemp failed");
    path_ = pattern;
  }
  ~TempDir() {
    std::error_code ec;
    std::filesystem::remove_all(path_, ec);
  }
  std::string file(const std::string& name) const { return (path_ / name).string(); }
  std::string path() const { return path_.string(); }

 private:
  std::filesystem::path path_;
};

inline void writeText(const std::string& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary);
  out << text;
}

inline std::string readText(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

// Runs `command` through the shell with its standard output and error captured in `output`;
// returns its exit code.
inline int runCommand(const std::string& command, std::string* output) {
  const char* tmp = std::getenv("TMPDIR");
  const std::string log = std::string(tmp ? tmp : "/tmp") + "/fluoro_test_command_" +
                          std::to_string(::getpid()) + ".log";
  const int status = std::system((command + " > " + log + " 2>&1").c_str());
  *output = readText(log);
  std::remove(log.c_str());
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

// Real data from ../shared/data beside the repository (see its README.md).
inline std::string sharedData(const std::string& relative) {
  return std::string(FLUORO_SHARED_DATA) + "/" + relative;
}

// Expects `statement` to throw an exception whose message contains `fragment`.
#define EXPECT_THROW_WITH(statement, fragment)                                    \
  do {                                                                            \
    try {                                                                         \
      statement;                                                                  \
      ADD_FAILURE() << "expected an exception containing '" << (fragment) << "'"; \
    } catch (const std::exception& e) {                                           \
      EXPECT_NE(std::string(e.what()).find(fragment), std::string::npos)          \
          << "message was: " << e.what();                                         \
    }                                                                             \
  } while (0)

}  // namespace test_support
}  // namespace fluoro_tracker
