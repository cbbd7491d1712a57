// bench_import — a 500-body MJCF model (ten chains of 50 hinged bodies with
// springs, hanging under gravity side by side): modal importing and analyzing it (load_model: MuJoCo's compile,
// the conversion and modal's scene reader; then analyze: equilibrium, exact
// M and K, all modes) against MuJoCo itself compiling the file and building
// M (mj_fullM) and a central-difference K (2n evaluations of
// qfrc_bias − qfrc_passive). Prints wall times (best of R runs) and the
// ratio; bench/import_chain.sh runs it and writes results/import_chain.md.
//
//   bench_import [BODIES] [REPEATS]
#include "modal/pipeline.hpp"

#include <mujoco/mujoco.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

namespace {

// MuJoCo's XML reader refuses elements nested more than about 100 deep, so
// the bodies hang in chains of at most 50 from the world, side by side.
std::string chains(int bodies) {
  std::string xml;
  for (int start = 0; start < bodies; start += 50) {
    std::string open, close;
    for (int i = start; i < std::min(bodies, start + 50); ++i) {
      const std::string pos = i == start ? std::to_string(0.2 * (start / 50)) + " 0 0" : "0 0 -0.1";
      open += "<body name=\"b" + std::to_string(i) + "\" pos=\"" + pos + "\">"
              "<joint name=\"j" + std::to_string(i) + "\" axis=\"" + (i % 2 ? "1 0 0" : "0 1 0") +
              "\" stiffness=\"50\" springref=\"0.01\"/>"
              "<geom type=\"capsule\" fromto=\"0 0 0 0 0 -0.1\" size=\"0.01\" mass=\"0.1\"/>\n";
      close += "</body>";
    }
    xml += open + close + "\n";
  }
  return "<mujoco model=\"chains\"><option><flag contact=\"disable\"/></option><worldbody>\n" + xml +
         "</worldbody></mujoco>\n";
}

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

}  // namespace

int main(int argc, char** argv) try {
  const int bodies = argc > 1 ? std::atoi(argv[1]) : 500;
  const int repeats = argc > 2 ? std::atoi(argv[2]) : 3;
  const std::string path = (std::filesystem::temp_directory_path() / ("bench_import_chain" + std::to_string(bodies) + ".xml")).string();
  std::ofstream(path) << chains(bodies);

  double best_modal = 1e300, best_load = 1e300, best_mujoco = 1e300, best_compile = 1e300;
  double omega1 = 0;
  for (int r = 0; r < repeats; ++r) {
    auto t0 = std::chrono::steady_clock::now();
    const modal::Model model = modal::load_model(path);
    const double load = seconds_since(t0);
    const modal::Analysis a = modal::analyze(model);
    best_modal = std::min(best_modal, seconds_since(t0));
    best_load = std::min(best_load, load);
    omega1 = a.result().modes.front().omega;

    t0 = std::chrono::steady_clock::now();
    char error[1000] = "";
    mjModel* m = mj_loadXML(path.c_str(), nullptr, error, sizeof error);
    if (m == nullptr) {
      std::fprintf(stderr, "MuJoCo: %s\n", error);
      return 1;
    }
    best_compile = std::min(best_compile, seconds_since(t0));
    mjData* d = mj_makeData(m);
    mj_forward(m, d);
    std::vector<mjtNum> M(static_cast<std::size_t>(m->nv) * static_cast<std::size_t>(m->nv));
    mj_fullM(m, M.data(), d->qM);
    std::vector<mjtNum> K(M.size()), fp(static_cast<std::size_t>(m->nv));
    const double h = 1e-6;
    for (int k = 0; k < m->nv; ++k) {
      const mjtNum q = d->qpos[k];
      d->qpos[k] = q + h;
      mj_forward(m, d);
      for (int i = 0; i < m->nv; ++i) fp[static_cast<std::size_t>(i)] = d->qfrc_bias[i] - d->qfrc_passive[i];
      d->qpos[k] = q - h;
      mj_forward(m, d);
      for (int i = 0; i < m->nv; ++i)
        K[static_cast<std::size_t>(i) * static_cast<std::size_t>(m->nv) + static_cast<std::size_t>(k)] =
            (fp[static_cast<std::size_t>(i)] - (d->qfrc_bias[i] - d->qfrc_passive[i])) / (2 * h);
      d->qpos[k] = q;
    }
    best_mujoco = std::min(best_mujoco, seconds_since(t0));
    mj_deleteData(d);
    mj_deleteModel(m);
  }
  std::printf("bodies %d, best of %d runs\n", bodies, repeats);
  std::printf("modal: import %.4f s, import + analyze (equilibrium, exact M and K, all %d modes) %.4f s; lowest omega %.9g rad/s\n",
              best_load, repeats > 0 ? bodies : 0, best_modal, omega1);
  std::printf("MuJoCo: compile %.4f s, compile + M + central-difference K (no equilibrium, no modes) %.4f s\n",
              best_compile, best_mujoco);
  std::printf("ratio modal / MuJoCo: %.3f\n", best_modal / best_mujoco);
  std::filesystem::remove(path);
  return 0;
} catch (const std::exception& e) {
  std::fprintf(stderr, "bench_import: %s\n", e.what());
  return 1;
}
