// lib/report/output.cpp — output files checked before computing and written
// all or none (modal/report.hpp).
#include "modal/report.hpp"

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <ostream>
#include <string>
#include <system_error>
#include <vector>

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

namespace modal {
namespace {

namespace fs = std::filesystem;

// The path as the file system sees it (symbolic links resolved as far as
// they exist), for comparing outputs with inputs and with each other.
fs::path canonical_form(const std::string& path) {
  std::error_code ec;
  fs::path p = fs::weakly_canonical(fs::absolute(path, ec), ec);
  return ec ? fs::path(path).lexically_normal() : p;
}

fs::path directory_of(const std::string& path) {
  const fs::path parent = fs::path(path).parent_path();
  return parent.empty() ? fs::path(".") : parent;
}

// A new, empty temporary file beside `path` (same directory, so that the
// final rename is atomic); its name in `temp`. -1 with errno on failure.
int open_temporary(const std::string& path, std::string& temp) {
  std::string pattern = (directory_of(path) / ("." + fs::path(path).filename().string() + ".modal-XXXXXX")).string();
  std::vector<char> buffer(pattern.begin(), pattern.end());
  buffer.push_back('\0');
  const int fd = mkstemp(buffer.data());
  if (fd >= 0) temp.assign(buffer.data());
  return fd;
}

}  // namespace

void check_output_paths(const std::vector<std::string>& outputs, const std::vector<std::string>& inputs) {
  std::vector<fs::path> seen;
  std::vector<fs::path> in;
  for (const std::string& i : inputs) in.push_back(canonical_form(i));
  for (const std::string& out : outputs) {
    if (out.empty()) continue;
    const fs::path c = canonical_form(out);
    for (const fs::path& i : in)
      if (c == i) throw ReportError(out + ": this output would overwrite an input of the run; choose another path");
    for (const fs::path& s : seen)
      if (c == s) throw ReportError(out + ": given as two outputs of the same run; choose distinct paths");
    seen.push_back(c);
    std::error_code ec;
    if (fs::is_directory(out, ec)) throw ReportError(out + ": cannot write the file: it is a directory");
    const fs::path dir = directory_of(out);
    if (!fs::is_directory(dir, ec))
      throw ReportError(out + ": cannot write the file: the directory " + dir.string() + " does not exist");
    std::string temp;
    const int fd = open_temporary(out, temp);
    if (fd < 0) throw ReportError(out + ": cannot write the file: " + std::strerror(errno));
    close(fd);
    std::remove(temp.c_str());
  }
}

void OutputFiles::add(std::string path, std::string content) { files_.emplace_back(std::move(path), std::move(content)); }

std::vector<std::string> OutputFiles::commit() {
  std::vector<std::string> temps;
  auto discard = [&temps] {
    for (const std::string& t : temps) std::remove(t.c_str());
  };
  for (const auto& [path, content] : files_) {
    std::string temp;
    const int fd = open_temporary(path, temp);
    if (fd < 0) {
      const std::string reason = std::strerror(errno);
      discard();
      throw ReportError(path + ": cannot write the file: " + reason);
    }
    temps.push_back(temp);
    const char* data = content.data();
    std::size_t left = content.size();
    while (left > 0) {
      const ssize_t n = write(fd, data, left);
      if (n < 0 && errno == EINTR) continue;
      if (n <= 0) {
        const std::string reason = n < 0 ? std::strerror(errno) : "nothing written";
        close(fd);
        discard();
        throw ReportError(path + ": writing failed (" + reason + "); no output file was changed");
      }
      data += n;
      left -= static_cast<std::size_t>(n);
    }
    // Permissions as an ordinary new file would get them (mkstemp makes 0600).
    const mode_t mask = umask(0);
    umask(mask);
    fchmod(fd, 0666 & ~mask);
    if (close(fd) != 0) {
      const std::string reason = std::strerror(errno);
      discard();
      throw ReportError(path + ": writing failed (" + reason + "); no output file was changed");
    }
  }
  std::vector<std::string> written;
  for (std::size_t i = 0; i < files_.size(); ++i) {
    if (std::rename(temps[i].c_str(), files_[i].first.c_str()) != 0) {
      const std::string reason = std::strerror(errno);
      for (std::size_t j = i; j < temps.size(); ++j) std::remove(temps[j].c_str());
      throw ReportError(files_[i].first + ": cannot replace the file (" + reason + ")");
    }
    written.push_back(files_[i].first);
  }
  files_.clear();
  return written;
}

void check_written(std::ostream& out, const std::string& what) {
  out.flush();
  if (!out) throw ReportError(what + ": writing failed (the output is incomplete: a full disk or a closed pipe)");
}

namespace {
double now_seconds() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}
}  // namespace

ProgressBar::ProgressBar(std::string label)
    : label_(std::move(label)), terminal_(isatty(STDERR_FILENO) == 1), start_(now_seconds()) {}

void ProgressBar::update(int done, int total) {
  if (!terminal_ || total <= 0) return;
  const double elapsed = now_seconds() - start_;
  if (elapsed < 1.0) return;
  constexpr int width = 30;
  const int filled = static_cast<int>(static_cast<long long>(width) * std::clamp(done, 0, total) / total);
  std::string line = "\r" + label_ + " [" + std::string(static_cast<std::size_t>(filled), '#') +
                     std::string(static_cast<std::size_t>(width - filled), ' ') + "] " + std::to_string(done) + "/" +
                     std::to_string(total);
  char buffer[64];
  std::snprintf(buffer, sizeof buffer, " %.1f s", elapsed);
  line += buffer;
  if (done > 0 && done < total) {
    std::snprintf(buffer, sizeof buffer, ", about %.0f s left  ", elapsed * (total - done) / done);
    line += buffer;
  }
  std::fputs(line.c_str(), stderr);
  std::fflush(stderr);
  shown_ = true;
}

void ProgressBar::finish() {
  if (shown_) {
    std::fputs(("\r" + std::string(78, ' ') + "\r").c_str(), stderr);
    std::fflush(stderr);
  }
  shown_ = false;
}

ProgressBar::~ProgressBar() { finish(); }

}  // namespace modal
