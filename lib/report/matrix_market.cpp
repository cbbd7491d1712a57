// Matrix Market export of linear models (`--export-matrices`).
#include "modal/report.hpp"

#include <algorithm>
#include <charconv>
#include <filesystem>
#include <fstream>
#include <system_error>

namespace modal {

void write_matrix_market(const TextSink& sink, const SparseMatrix& A, bool symmetric, const std::string& comment) {
  Eigen::Index entries = 0;
  for (Eigen::Index k = 0; k < A.outerSize(); ++k)
    for (SparseMatrix::InnerIterator it(A, k); it; ++it)
      if (!symmetric || it.row() >= it.col()) ++entries;
  std::string buffer;
  buffer.reserve(1 << 20);
  buffer += std::string("%%MatrixMarket matrix coordinate real ") + (symmetric ? "symmetric" : "general") + "\n";
  if (!comment.empty()) buffer += "% " + comment + "\n";
  char number[64];
  auto append = [&](auto value, char end) {
    const auto r = std::to_chars(number, number + sizeof number, value);  // doubles: shortest round-trip form
    buffer.append(number, r.ptr);
    buffer.push_back(end);
  };
  append(A.rows(), ' ');
  append(A.cols(), ' ');
  append(entries, '\n');
  for (Eigen::Index k = 0; k < A.outerSize(); ++k)
    for (SparseMatrix::InnerIterator it(A, k); it; ++it) {
      if (symmetric && it.row() < it.col()) continue;
      append(it.row() + 1, ' ');
      append(it.col() + 1, ' ');
      append(it.value(), '\n');
      if (buffer.size() > (1 << 20) - 128) {
        sink(buffer);
        buffer.clear();
      }
    }
  sink(buffer);
}

void write_matrix_market(const std::string& path, const SparseMatrix& A, bool symmetric, const std::string& comment) {
  std::ofstream out(path, std::ios::binary);
  if (!out) throw ReportError(path + ": cannot open the file for writing");
  write_matrix_market([&](std::string_view text) { out.write(text.data(), static_cast<std::streamsize>(text.size())); },
                      A, symmetric, comment);
  if (!out) throw ReportError(path + ": writing failed");
}

namespace {

std::string in(const std::string& dir, const char* name) { return (std::filesystem::path(dir) / name).string(); }

// DIR's exported matrices that this export does not write: removed when the
// files are in place.
void remove_stale(OutputFiles& files, const std::string& dir, const std::vector<std::string>& written) {
  for (const char* name : exported_matrix_names) {
    const std::string path = in(dir, name);
    if (std::find(written.begin(), written.end(), path) == written.end()) files.remove_after(path);
  }
}

}  // namespace

std::vector<std::string> add_matrix_exports(OutputFiles& files, const std::string& dir, const LinearModel& model) {
  files.add_directory(dir);
  std::vector<std::string> written;
  auto put = [&](const char* name, const MatrixX& A, bool symmetric, const std::string& what) {
    written.push_back(in(dir, name));
    files.add(written.back(), [&A, symmetric, what](const TextSink& sink) {
      write_matrix_market(sink, A.sparseView(), symmetric, what);
    });
  };
  const std::string where = model.constrained() ? " on the constraint manifold (coordinates: N.mtx columns)" : "";
  put("M.mtx", model.M, true, "mass matrix M" + where);
  put("K.mtx", model.K, !model.circulatory, "stiffness matrix K" + where);
  if (model.has_damping) put("D.mtx", model.D, true, "damping matrix D" + where);
  if (model.has_gyroscopic) put("G.mtx", model.G, false, "gyroscopic matrix G (skew)" + where);
  if (model.constrained()) put("N.mtx", model.basis, false, "null-space basis N: coordinates = N × manifold coordinates");
  remove_stale(files, dir, written);
  return written;
}

std::vector<std::string> add_matrix_exports(OutputFiles& files, const std::string& dir,
                                            const SparseLinearModel& model) {
  files.add_directory(dir);
  std::vector<std::string> written{in(dir, "M.mtx"), in(dir, "K.mtx")};
  files.add(written[0], [&model](const TextSink& sink) { write_matrix_market(sink, model.M, true, "mass matrix M"); });
  files.add(written[1],
            [&model](const TextSink& sink) { write_matrix_market(sink, model.K, true, "stiffness matrix K"); });
  remove_stale(files, dir, written);
  return written;
}

std::vector<std::string> export_matrices(const std::string& dir, const LinearModel& model) {
  OutputFiles files;
  std::vector<std::string> written = add_matrix_exports(files, dir, model);
  files.commit();
  return written;
}

std::vector<std::string> export_matrices(const std::string& dir, const SparseLinearModel& model) {
  OutputFiles files;
  std::vector<std::string> written = add_matrix_exports(files, dir, model);
  files.commit();
  return written;
}

}  // namespace modal
