// CSV of a simulated trajectory (`modal simulate`).
#include "modal/report.hpp"

#include <ostream>

namespace modal {

void write_trajectory_csv(std::ostream& out, const Trajectory& tr) {
  const std::size_t n = tr.q.empty() ? tr.coordinates.size() : static_cast<std::size_t>(tr.q.front().size());
  auto name = [&](std::size_t i) { return i < tr.coordinates.size() ? tr.coordinates[i] : "q" + std::to_string(i + 1); };
  out << "time";
  for (std::size_t i = 0; i < n; ++i) out << ',' << csv_field(name(i));
  for (std::size_t i = 0; i < n; ++i) out << ',' << csv_field(name(i) + "_dot");
  out << ",energy,work,energy_error\n";
  for (std::size_t k = 0; k < tr.size(); ++k) {
    out << csv_number(tr.time[k]);
    for (std::size_t i = 0; i < n; ++i) out << ',' << csv_number(tr.q[k][static_cast<Eigen::Index>(i)]);
    for (std::size_t i = 0; i < n; ++i) out << ',' << csv_number(tr.qd[k][static_cast<Eigen::Index>(i)]);
    out << ',' << csv_number(tr.energy[k]) << ',' << csv_number(tr.work[k]) << ',' << csv_number(tr.energy_error[k])
        << '\n';
  }
}

}  // namespace modal
