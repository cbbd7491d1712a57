// Matrix Market export of linear models (`--export-matrices`).
#include "modal/report.hpp"

#include <algorithm>
#include <charconv>
#include <filesystem>
#include <fstream>
#include <system_error>

namespace modal {

void write_matrix_market(const std::string& path, const SparseMatrix& A, bool symmetric, const std::string& comment) {
  std::ofstream out(path, std::ios::binary);
  if (!out) throw ReportError(path + ": cannot open the file for writing");
  Eigen::Index entries = 0;
  for (Eigen::Index k = 0; k < A.outerSize(); ++k)
    for (SparseMatrix::InnerIterator it(A, k); it; ++it)
      if (!symmetric || it.row() >= it.col()) ++entries;
  out << "%%MatrixMarket matrix coordinate real " << (symmetric ? "symmetric" : "general") << "\n";
  if (!comment.empty()) out << "% " << comment << "\n";
  out << A.rows() << ' ' << A.cols() << ' ' << entries << '\n';
  std::string buffer;
  buffer.reserve(1 << 20);
  char number[64];
  auto append = [&](auto value, char end) {
    const auto r = std::to_chars(number, number + sizeof number, value);  // doubles: shortest round-trip form
    buffer.append(number, r.ptr);
    buffer.push_back(end);
  };
  for (Eigen::Index k = 0; k < A.outerSize(); ++k)
    for (SparseMatrix::InnerIterator it(A, k); it; ++it) {
      if (symmetric && it.row() < it.col()) continue;
      append(it.row() + 1, ' ');
      append(it.col() + 1, ' ');
      append(it.value(), '\n');
      if (buffer.size() > (1 << 20) - 128) {
        out.write(buffer.data(), static_cast<std::streamsize>(buffer.size()));
        buffer.clear();
      }
    }
  out.write(buffer.data(), static_cast<std::streamsize>(buffer.size()));
  if (!out) throw ReportError(path + ": writing failed");
}

namespace {

void make_directory(const std::string& dir) {
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec || !std::filesystem::is_directory(dir))
    throw ReportError(dir + ": cannot create the directory" + (ec ? " (" + ec.message() + ")" : std::string(": a file of this name exists")));
}

std::string in(const std::string& dir, const char* name) { return (std::filesystem::path(dir) / name).string(); }

// Removes DIR's exported matrices that this export did not write.
void remove_stale(const std::string& dir, const std::vector<std::string>& written) {
  for (const char* name : exported_matrix_names) {
    const std::string path = in(dir, name);
    if (std::find(written.begin(), written.end(), path) != written.end()) continue;
    std::error_code ec;
    if (std::filesystem::is_regular_file(path, ec) && !std::filesystem::remove(path, ec))
      throw ReportError(path + ": cannot remove the matrix of an earlier export (" + ec.message() + ")");
  }
}

}  // namespace

std::vector<std::string> export_matrices(const std::string& dir, const LinearModel& model) {
  make_directory(dir);
  std::vector<std::string> written;
  auto put = [&](const char* name, const MatrixX& A, bool symmetric, const std::string& what) {
    written.push_back(in(dir, name));
    write_matrix_market(written.back(), A.sparseView(), symmetric, what);
  };
  const std::string where = model.constrained() ? " on the constraint manifold (coordinates: N.mtx columns)" : "";
  put("M.mtx", model.M, true, "mass matrix M" + where);
  put("K.mtx", model.K, !model.circulatory, "stiffness matrix K" + where);
  if (model.has_damping) put("D.mtx", model.D, true, "damping matrix D" + where);
  if (model.has_gyroscopic) put("G.mtx", model.G, false, "gyroscopic matrix G (skew)" + where);
  if (model.constrained()) put("N.mtx", model.basis, false, "null-space basis N: coordinates = N × manifold coordinates");
  remove_stale(dir, written);
  return written;
}

std::vector<std::string> export_matrices(const std::string& dir, const SparseLinearModel& model) {
  make_directory(dir);
  std::vector<std::string> written{in(dir, "M.mtx"), in(dir, "K.mtx")};
  write_matrix_market(written[0], model.M, true, "mass matrix M");
  write_matrix_market(written[1], model.K, true, "stiffness matrix K");
  remove_stale(dir, written);
  return written;
}

}  // namespace modal
