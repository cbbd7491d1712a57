// Cost of linearizing expression-defined systems (kinematic maps, issue
// "systems written as kinematic maps"): the spherical pendulum in spherical
// angles about its conical motion (Routh's reduction over the ignorable
// azimuth), the Foucault pendulum (a steadily moving map) and the double
// pendulum written as a map, against the same double pendulum written as
// bodies. Each "Linearize" is modal::linearize at the equilibrium (exact
// gradient check, ∇∇V_eff, M and G by AD through the expressions);
// "Analyze" adds the equilibrium search and the modal solution; "Load"
// parses and validates the scene (expression compilation and the map's
// steadiness checks).
//
//   build/bench/bench_map              (bench/map_linearize.sh writes results/map_linearize.md)
#include "modal/equilibrium.hpp"
#include "modal/linearize.hpp"
#include "modal/modes.hpp"
#include "modal/scene.hpp"

#include <benchmark/benchmark.h>

#include <string>

namespace {

std::string model(const char* name) { return std::string(MODAL_SOURCE_DIR) + "/models/" + name + ".toml"; }

const char* const names[] = {"spherical_pendulum_angles", "foucault", "double_pendulum_map", "double_pendulum",
                             "spinning_top"};

void Load(benchmark::State& st) {
  const std::string path = model(names[st.range(0)]);
  st.SetLabel(names[st.range(0)]);
  for (auto _ : st) benchmark::DoNotOptimize(modal::build_system(modal::load_scene(path)));
}

void Linearize(benchmark::State& st) {
  const modal::System s = modal::build_system(modal::load_scene(model(names[st.range(0)])));
  const modal::Equilibrium e = modal::find_equilibrium(s, s.initial_configuration());
  st.SetLabel(names[st.range(0)]);
  for (auto _ : st) benchmark::DoNotOptimize(modal::linearize(s, e.q));
}

void Analyze(benchmark::State& st) {
  const modal::System s = modal::build_system(modal::load_scene(model(names[st.range(0)])));
  st.SetLabel(names[st.range(0)]);
  for (auto _ : st) {
    const modal::Equilibrium e = modal::find_equilibrium(s, s.initial_configuration());
    benchmark::DoNotOptimize(modal::solve_modes(modal::linearize(s, e.q)));
  }
}

}  // namespace

BENCHMARK(Load)->DenseRange(0, 4)->Unit(benchmark::kMicrosecond);
BENCHMARK(Linearize)->DenseRange(0, 4)->Unit(benchmark::kMicrosecond);
BENCHMARK(Analyze)->DenseRange(0, 4)->Unit(benchmark::kMicrosecond);

BENCHMARK_MAIN();
