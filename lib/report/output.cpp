// lib/report/output.cpp — output files checked before computing and written
// all or none (modal/report.hpp).
#include "modal/report.hpp"

#include <algorithm>
#include <cstdlib>
#include <array>
#include <atomic>
#include <csignal>
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

// Paths the signal handler must remove: fixed slots of heap copies of the
// names, claimed and released with atomic exchanges, so that the handler
// (which may only call async-signal-safe functions) reads them without locks.
// A run has a handful of outputs; when every slot is taken a path is simply
// not removed on a signal.
template <std::size_t N>
struct LivePaths {
  static constexpr std::size_t none = N;
  std::array<std::atomic<char*>, N> slots{};
  // Registers `path` in a free slot; the slot's index, or `none`.
  std::size_t claim(const std::string& path) {
    char* copy = new char[path.size() + 1];
    std::memcpy(copy, path.c_str(), path.size() + 1);
    for (std::size_t i = 0; i < N; ++i) {
      char* expected = nullptr;
      if (slots[i].compare_exchange_strong(expected, copy)) return i;
    }
    delete[] copy;
    return none;
  }
  // Forgets the path of `slot` (kept, or removed already).
  void release(std::size_t slot) {
    if (slot < N) delete[] slots[slot].exchange(nullptr);
  }
};

// The temporary files that exist at this moment, and the directories a commit
// has created and not yet kept (a complete commit keeps them): the handler
// removes the directories after the temporaries that were in them (rmdir,
// async-signal-safe, removes only empty ones).
LivePaths<64> live_temporaries;
LivePaths<16> live_directories;
constexpr std::size_t temporary_slots = decltype(live_temporaries)::none;

// Removes the registered directories that are empty, children before their
// parents (a pass per level, at most one per slot).
void remove_live_directories() noexcept {
  for (std::size_t pass = 0; pass < live_directories.slots.size(); ++pass) {
    bool removed = false;
    for (std::atomic<char*>& slot : live_directories.slots) {
      const char* name = slot.load();
      if (name != nullptr && rmdir(name) == 0) removed = true;
    }
    if (!removed) return;
  }
}

// A temporary file: removed (and released) when it goes out of scope unless
// kept, i.e. renamed into place.
struct Temporary {
  std::string path;
  std::size_t slot = temporary_slots;
  bool kept = false;
  Temporary() = default;
  Temporary(const Temporary&) = delete;
  Temporary& operator=(const Temporary&) = delete;
  ~Temporary() {
    if (!path.empty() && !kept) std::remove(path.c_str());
    live_temporaries.release(slot);
  }
};

// A new, empty temporary file beside `path` (same directory, so that the
// final rename is atomic), registered for removal on a signal; its name in
// `temp`. -1 with errno on failure.
int open_temporary(const std::string& path, Temporary& temp) {
  std::string pattern = (directory_of(path) / ("." + fs::path(path).filename().string() + ".modal-XXXXXX")).string();
  std::vector<char> buffer(pattern.begin(), pattern.end());
  buffer.push_back('\0');
  // The slot is taken before the file exists, so that no signal finds a file
  // without a registration; its name is then filled in by mkstemp.
  temp.slot = live_temporaries.claim(pattern);
  char* slot_name = temp.slot < temporary_slots ? live_temporaries.slots[temp.slot].load() : nullptr;
  const int fd = mkstemp(slot_name != nullptr ? slot_name : buffer.data());
  if (fd >= 0) temp.path.assign(slot_name != nullptr ? slot_name : buffer.data());
  return fd;
}

// The renames of one commit are made indivisible for the signal handlers: a
// signal that arrives while they run (state renaming) is held in `pending`
// and acted on when they are done; a handler that has begun to end the
// process (state dying) keeps commit from starting them. The handler may run
// on any thread (OpenBLAS's included), hence atomics, not a signal mask.
enum CommitState : int { idle = 0, renaming = 1, dying = 2 };
std::atomic<int> commit_state{idle};
std::atomic<int> pending_signal{0};

extern "C" void remove_temporaries_and_reraise(int signal) {
  int expected = idle;
  if (!commit_state.compare_exchange_strong(expected, dying)) {
    if (expected == renaming) {
      pending_signal.store(signal);
      return;  // acted on when the renames are done
    }
  }
  remove_output_temporaries();
  std::signal(signal, SIG_DFL);
  std::raise(signal);
}

// Enters the renaming state; never returns when a handler is ending the process.
void begin_renames() {
  int expected = idle;
  while (!commit_state.compare_exchange_strong(expected, renaming)) {
    if (expected == dying) pause();  // the process is being ended by a signal
    expected = idle;
  }
}

// Leaves it, and acts on a signal that came meanwhile.
void end_renames() {
  commit_state.store(idle);
  // Through the handler's own path (default action, then raise): a handler
  // the program put in front (apps/modal/main.cpp) must not take this
  // raise, sent by the process itself, for a library's.
  if (const int signal = pending_signal.exchange(0); signal != 0) remove_temporaries_and_reraise(signal);
}

}  // namespace

void check_not_inputs(const std::vector<std::string>& outputs, const std::vector<std::string>& inputs) {
  std::vector<fs::path> in;
  for (const std::string& i : inputs) in.push_back(canonical_form(i));
  for (const std::string& out : outputs) {
    if (out.empty()) continue;
    const fs::path c = canonical_form(out);
    for (const fs::path& i : in)
      if (c == i) throw ReportError(out + ": this output would overwrite an input of the run; choose another path");
  }
}

void check_output_paths(const std::vector<std::string>& outputs, const std::vector<std::string>& inputs) {
  check_not_inputs(outputs, inputs);
  std::vector<fs::path> seen;
  for (const std::string& out : outputs) {
    if (out.empty()) continue;
    const fs::path c = canonical_form(out);
    for (const fs::path& s : seen)
      if (c == s) throw ReportError(out + ": given as two outputs of the same run; choose distinct paths");
    seen.push_back(c);
    std::error_code ec;
    if (fs::is_directory(out, ec)) throw ReportError(out + ": cannot write the file: it is a directory");
    const fs::path dir = directory_of(out);
    if (!fs::is_directory(dir, ec))
      throw ReportError(out + ": cannot write the file: the directory " + dir.string() + " does not exist");
    Temporary temp;
    const int fd = open_temporary(out, temp);
    if (fd < 0) throw ReportError(out + ": cannot write the file: " + std::strerror(errno));
    close(fd);
  }
}

void check_output_directory(const std::string& dir, const std::vector<std::string>& others) {
  std::error_code ec;
  if (fs::exists(dir, ec) && !fs::is_directory(dir, ec))
    throw ReportError(dir + ": --export-matrices writes M.mtx, K.mtx, … into a directory, and this path is a file; "
                      "choose a directory (it is created if it does not exist)");
  const fs::path c = canonical_form(dir);
  for (const std::string& o : others) {
    if (o.empty()) continue;
    const fs::path other = canonical_form(o);
    if (other == c) throw ReportError(dir + ": --export-matrices names the path of another output or input of the run");
    for (const char* name : exported_matrix_names)
      if (other == canonical_form((fs::path(dir) / name).string()))
        throw ReportError(o + ": an output or input of the run would be " + name + " of --export-matrices " + dir +
                          "; choose distinct paths");
  }
}

void remove_output_temporaries() noexcept {
  for (std::atomic<char*>& slot : live_temporaries.slots) {
    const char* name = slot.load();
    if (name != nullptr) unlink(name);  // async-signal-safe; a name not yet made by mkstemp is not a file
  }
  remove_live_directories();
}

void remove_output_temporaries_on_signals() {
  for (int signal : {SIGINT, SIGTERM, SIGHUP}) std::signal(signal, remove_temporaries_and_reraise);
}

void OutputFiles::add(std::string path, std::string content) {
  files_.push_back({std::move(path), std::move(content), nullptr});
}

void OutputFiles::add(std::string path, std::function<void(const TextSink&)> writer) {
  files_.push_back({std::move(path), std::string(), std::move(writer)});
}

void OutputFiles::remove_after(std::string path) { removals_.push_back(std::move(path)); }

void OutputFiles::add_directory(std::string path) { directories_.push_back(std::move(path)); }

namespace {

// The directories a commit created: removed on every way out but a complete
// commit (they are empty then: their files were temporaries), by the
// destructor or, on an interrupt, by the signal handler (registered before
// they exist, as the temporaries are).
struct CreatedDirectories {
  std::vector<fs::path> paths;
  std::vector<std::size_t> slots;
  bool kept = false;
  CreatedDirectories() = default;
  CreatedDirectories(const CreatedDirectories&) = delete;
  CreatedDirectories& operator=(const CreatedDirectories&) = delete;
  ~CreatedDirectories() {
    if (!kept) {
      // Children before their parents: a longer normal path is never an ancestor of a shorter one.
      std::sort(paths.begin(), paths.end(),
                [](const fs::path& a, const fs::path& b) { return a.native().size() > b.native().size(); });
      std::error_code ec;
      for (const fs::path& p : paths) fs::remove(p, ec);  // removes nothing that is not empty
    }
    for (const std::size_t slot : slots) live_directories.release(slot);
  }
  void create(const std::string& dir) {
    std::error_code ec;
    std::vector<fs::path> missing;
    for (fs::path p = fs::absolute(dir, ec).lexically_normal(); !p.empty() && !fs::exists(p, ec); p = p.parent_path()) {
      missing.push_back(p);
      if (p == p.parent_path()) break;
    }
    for (const fs::path& p : missing) slots.push_back(live_directories.claim(p.string()));
    fs::create_directories(dir, ec);
    for (const fs::path& p : missing)
      if (fs::is_directory(p)) paths.push_back(p);
    if (ec || !fs::is_directory(dir))
      throw ReportError(dir + ": cannot create the directory" +
                        (ec ? " (" + ec.message() + ")" : std::string(": a file of this name exists")));
  }
};

}  // namespace

std::vector<std::string> OutputFiles::commit() {
  CreatedDirectories created;
  for (const std::string& dir : directories_) created.create(dir);
  // Removed on every way out but a complete rename (destructors), and by the
  // signal handler while they exist.
  std::vector<Temporary> temps(files_.size());
  for (std::size_t f = 0; f < files_.size(); ++f) {
    const std::string& path = files_[f].path;
    const int fd = open_temporary(path, temps[f]);
    if (fd < 0) {
      const std::string reason = std::strerror(errno);
      throw ReportError(path + ": cannot write the file: " + reason);
    }
    const TextSink sink = [&](std::string_view text) {
      const char* data = text.data();
      std::size_t left = text.size();
      while (left > 0) {
        const ssize_t n = write(fd, data, left);
        if (n < 0 && errno == EINTR) continue;
        if (n <= 0) {
          const std::string reason = n < 0 ? std::strerror(errno) : "nothing written";
          throw ReportError(path + ": writing failed (" + reason + "); no output file was changed");
        }
        data += n;
        left -= static_cast<std::size_t>(n);
      }
    };
    try {
      if (files_[f].writer) {
        files_[f].writer(sink);
      } else {
        sink(files_[f].content);
      }
    } catch (...) {
      close(fd);  // the temporary itself is removed by its destructor
      throw;
    }
    // Permissions as an ordinary new file would get them (mkstemp makes 0600).
    const mode_t mask = umask(0);
    umask(mask);
    fchmod(fd, 0666 & ~mask);
    if (close(fd) != 0) {
      const std::string reason = std::strerror(errno);
      throw ReportError(path + ": writing failed (" + reason + "); no output file was changed");
    }
  }
  std::vector<std::string> written;
  begin_renames();
  for (std::size_t i = 0; i < files_.size(); ++i) {
    if (std::rename(temps[i].path.c_str(), files_[i].path.c_str()) != 0) {
      const std::string reason = std::strerror(errno);
      end_renames();
      throw ReportError(files_[i].path + ": cannot replace the file (" + reason + ")");
    }
    temps[i].kept = true;
    written.push_back(files_[i].path);
  }
  end_renames();
  created.kept = true;
  files_.clear();
  directories_.clear();
  std::vector<std::string> removals = std::move(removals_);
  removals_.clear();
  // Every stale file is tried; those that stay are named together.
  std::string failed;
  for (const std::string& path : removals) {
    std::error_code ec;
    if (std::find(written.begin(), written.end(), path) != written.end() || !fs::is_regular_file(path, ec)) continue;
    if (!fs::remove(path, ec) && ec)  // false without an error: it is gone already
      failed += (failed.empty() ? "" : "; ") + path + " (" + ec.message() + ")";
  }
  if (!failed.empty())
    throw ReportError("cannot remove the output of an earlier run: " + failed + "; this run's files were written");
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

namespace {
// A continuous-integration run (CI=true, as most CI services set it).
bool in_ci() {
  const char* ci = std::getenv("CI");
  if (!ci) return false;
  const std::string v(ci);
  return !(v.empty() || v == "0" || v == "false");
}
}  // namespace

ProgressBar::ProgressBar(std::string label, bool shown)
    : label_(std::move(label)), terminal_(shown && isatty(STDERR_FILENO) == 1 && !in_ci()), start_(now_seconds()) {}

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
