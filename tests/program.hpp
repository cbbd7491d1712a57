// Running the built `modal` program (MODAL_BINARY) for the end-to-end tests:
// its exit status and what it wrote on stdout and stderr.
#pragma once

#include <gtest/gtest.h>

#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

namespace modal::test {

struct Outcome {
  int status = -1;
  std::string out, err;
};

inline std::string slurp(const std::filesystem::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

// The argument in single quotes for /bin/sh.
inline std::string quote(const std::string& s) {
  std::string q = "'";
  for (char c : s) q += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return q + "'";
}

// Runs `modal args…` with stdout and stderr captured in files in `dir`.
inline Outcome run_modal(const std::vector<std::string>& args, const std::filesystem::path& dir) {
  std::string cmd = quote(MODAL_BINARY);
  for (const auto& a : args) cmd += " " + quote(a);
  const std::filesystem::path out = dir / "stdout.txt", err = dir / "stderr.txt";
  cmd += " >" + quote(out.string()) + " 2>" + quote(err.string());
  const int raw = std::system(cmd.c_str());
  Outcome r;
  r.status = WIFEXITED(raw) ? WEXITSTATUS(raw) : 128 + (WIFSIGNALED(raw) ? WTERMSIG(raw) : 0);
  r.out = slurp(out);
  r.err = slurp(err);
  return r;
}

// A test with its own empty directory, <temp>/<prefix><pid>_<test name>,
// removed afterwards unless the test failed (then kept for inspection); run()
// runs the program with its output captured there.
class ProgramTest : public ::testing::Test {
 protected:
  explicit ProgramTest(std::string prefix) : prefix_(std::move(prefix)) {}

  std::filesystem::path dir;

  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir = std::filesystem::temp_directory_path() / (prefix_ + std::to_string(::getpid()) + "_" + info->name());
    std::filesystem::remove_all(dir);
    std::filesystem::create_directories(dir);
  }
  void TearDown() override {
    if (!HasFailure()) std::filesystem::remove_all(dir);
  }
  Outcome run(const std::vector<std::string>& args) const { return run_modal(args, dir); }

 private:
  std::string prefix_;
};

}  // namespace modal::test
