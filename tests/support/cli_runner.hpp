#pragma once
// Helpers for tests that drive the built `voxpack` binary and use scratch folders.
#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "voxpack_test_paths.hpp"

namespace voxpack::test {

/// What a command printed and how it exited.
struct CliResult {
  int exitCode = -1;   ///< process exit status (128+signal when killed)
  std::string out;     ///< stdout
  std::string err;     ///< stderr
};

/// Quotes one shell word.
inline std::string shellQuote(const std::string& s) {
  std::string q = "'";
  for (char c : s) q += (c == '\'') ? std::string("'\\''") : std::string(1, c);
  return q + "'";
}

/// A scratch folder removed at destruction.
class TempDir {
 public:
  TempDir() {
    std::random_device rd;
    path_ = std::filesystem::temp_directory_path() /
            ("voxpack_test_" + std::to_string(getpid()) + "_" + std::to_string(rd()));
    std::filesystem::create_directories(path_);
  }
  ~TempDir() {
    std::error_code ec;
    std::filesystem::remove_all(path_, ec);
  }
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
  const std::filesystem::path& path() const { return path_; }
  std::filesystem::path operator/(const std::string& name) const { return path_ / name; }

 private:
  std::filesystem::path path_;
};

/// Runs `voxpack ARGS...` (args are quoted), capturing stdout and stderr.
inline CliResult runVoxpack(const std::vector<std::string>& args) {
  TempDir tmp;
  std::string cmd = shellQuote(VOXPACK_BINARY);
  for (const auto& a : args) cmd += " " + shellQuote(a);
  const auto outPath = tmp / "out.txt";
  const auto errPath = tmp / "err.txt";
  cmd += " >" + shellQuote(outPath.string()) + " 2>" + shellQuote(errPath.string()) + " </dev/null";
  const int status = std::system(cmd.c_str());
  CliResult r;
  if (WIFEXITED(status))
    r.exitCode = WEXITSTATUS(status);
  else if (WIFSIGNALED(status))
    r.exitCode = 128 + WTERMSIG(status);
  auto slurp = [](const std::filesystem::path& p) {
    std::ifstream f(p);
    std::stringstream ss;
    ss << f.rdbuf();
    return ss.str();
  };
  r.out = slurp(outPath);
  r.err = slurp(errPath);
  return r;
}

/// Runs a shell command line, returning its exit code.
inline int runShell(const std::string& cmd) {
  const int status = std::system(cmd.c_str());
  return WIFEXITED(status) ? WEXITSTATUS(status) : 128;
}

/// Counts the lines of `text` that start with "error: ".
inline int countErrorLines(const std::string& text) {
  int n = 0;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);)
    if (line.rfind("error: ", 0) == 0) ++n;
  return n;
}

/// Files in `dir` (non-recursive), for "no partial file left behind" checks.
inline std::vector<std::string> listDir(const std::filesystem::path& dir) {
  std::vector<std::string> v;
  for (const auto& e : std::filesystem::directory_iterator(dir)) v.push_back(e.path().filename());
  return v;
}

}  // namespace voxpack::test
