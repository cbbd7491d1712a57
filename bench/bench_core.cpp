// Cost of the core's exact derivatives on hanging chains of N links (scene
// generator `[[chain]]`), against nested forward-mode AD through the same
// templated model (the straightforward way to get a Hessian by AD).
//
//   build/bench/bench_core --benchmark_out=results/bench_core.json --benchmark_out_format=json
#include "modal/core.hpp"
#include "modal/scene.hpp"

#include "core/model.hpp"

#include <benchmark/benchmark.h>

#include <string>

namespace {

modal::System chain(int links) {
  const std::string text = "title = \"bench chain\"\n[[chain]]\nname = \"c\"\nlinks = " + std::to_string(links) +
                           "\nlength = 1.0\nmass = 1.0\nstiffness = 0.5\n";
  return modal::build_system(modal::parse_scene(text, "bench.toml"));
}

// A flat particle net of side×side nodes, boundary fixed (scene generator
// `[[lattice]]`), springs at their rest length (slack) unless `prestrain`.
modal::System net(int side, double prestrain) {
  const std::string text = "title = \"bench net\"\ngravity = [0, 0, -9.81]\n[[lattice]]\nname = \"n\"\nsize = [" +
                           std::to_string(side) + ", " + std::to_string(side) +
                           ", 1]\nspacing = 0.1\nmass = 0.002\nstiffness = 1000\nprestrain = " +
                           std::to_string(prestrain) + "\nfixed = \"boundary\"\n";
  return modal::build_system(modal::parse_scene(text, "bench.toml"));
}

Eigen::VectorXd state(const modal::System& s) {
  Eigen::VectorXd q(s.size());
  for (int i = 0; i < s.size(); ++i) q[i] = 0.3 * std::sin(0.7 * i);
  return q;
}

void Gradient(benchmark::State& st) {
  const modal::System s = chain(static_cast<int>(st.range(0)));
  modal::Workspace w(s);
  const Eigen::VectorXd q = state(s);
  for (auto _ : st) benchmark::DoNotOptimize(modal::potential_gradient(s, w, q).data());
  st.SetComplexityN(st.range(0));
}

void Hessian(benchmark::State& st) {
  const modal::System s = chain(static_cast<int>(st.range(0)));
  modal::Workspace w(s);
  const Eigen::VectorXd q = state(s);
  for (auto _ : st) benchmark::DoNotOptimize(modal::potential_hessian(s, w, q).data());
  st.SetComplexityN(st.range(0));
}

void MassMatrix(benchmark::State& st) {
  const modal::System s = chain(static_cast<int>(st.range(0)));
  modal::Workspace w(s);
  const Eigen::VectorXd q = state(s);
  for (auto _ : st) benchmark::DoNotOptimize(modal::mass_matrix(s, w, q).data());
  st.SetComplexityN(st.range(0));
}

// The sparse ∇∇V of a net (the large equilibrium's and the sparse modes
// stage's assembly) at a sagged, wrinkled configuration, in place on the
// pattern of an earlier call; argument: the side, n ≈ 3·side² coordinates.
void SparseHessianNet(benchmark::State& st) {
  const modal::System s = net(static_cast<int>(st.range(0)), 0.0);
  modal::Workspace w(s);
  Eigen::VectorXd q(s.size());
  for (int i = 0; i < s.size(); ++i) q[i] = 1e-3 * std::sin(0.7 * i) - (i % 3 == 2 ? 0.05 : 0.0);
  modal::sparse_potential_hessian(s, w, q);  // the pattern (SparseHessianNetFirst): what follows is in place
  for (auto _ : st) benchmark::DoNotOptimize(modal::sparse_potential_hessian(s, w, q).valuePtr());
  st.SetComplexityN(s.size());
}

// The first assembly in a fresh workspace, which also builds the pattern
// (assemble_by_columns in lib/core/derivatives.cpp).
void SparseHessianNetFirst(benchmark::State& st) {
  const modal::System s = net(static_cast<int>(st.range(0)), 0.0);
  Eigen::VectorXd q(s.size());
  for (int i = 0; i < s.size(); ++i) q[i] = 1e-3 * std::sin(0.7 * i) - (i % 3 == 2 ? 0.05 : 0.0);
  for (auto _ : st) {
    st.PauseTiming();
    modal::Workspace w(s);
    st.ResumeTiming();
    benchmark::DoNotOptimize(modal::sparse_potential_hessian(s, w, q).valuePtr());
  }
  st.SetComplexityN(s.size());
}

// Nested forward AD, one Hessian column per pass with B inner directions at a
// time: what a Hessian by plain AD through the tree costs.
// The tension metric of the damped steps (sparse_tension_metric) on the
// pattern of an earlier ∇∇V, in place, as the large equilibrium takes it;
// and in a workspace without one (assemble_by_columns).
void TensionMetricNet(benchmark::State& st) {
  const modal::System s = net(static_cast<int>(st.range(0)), 0.0);
  modal::Workspace w(s);
  const Eigen::VectorXd q = Eigen::VectorXd::Zero(s.size());
  modal::sparse_potential_hessian(s, w, q);
  for (auto _ : st) benchmark::DoNotOptimize(modal::sparse_tension_metric(s, w, q).valuePtr());
  st.SetComplexityN(s.size());
}

void TensionMetricNetFresh(benchmark::State& st) {
  const modal::System s = net(static_cast<int>(st.range(0)), 0.0);
  modal::Workspace w(s);
  const Eigen::VectorXd q = Eigen::VectorXd::Zero(s.size());
  for (auto _ : st) benchmark::DoNotOptimize(modal::sparse_tension_metric(s, w, q).valuePtr());
  st.SetComplexityN(s.size());
}

void HessianNestedAD(benchmark::State& st) {
  const modal::System s = chain(static_cast<int>(st.range(0)));
  const Eigen::VectorXd q = state(s);
  const int n = s.size();
  constexpr int B = 8;
  using D = modal::Dual<modal::Dual<double, B>, 1>;
  Eigen::MatrixXd H(n, n);
  modal::model::TreeState<D> ts;
  modal::model::VX<D> qd(n);
  for (auto _ : st) {
    for (int j = 0; j < n; ++j)
      for (int i0 = 0; i0 < n; i0 += B) {
        for (int k = 0; k < n; ++k) {
          qd[k] = D(modal::Dual<double, B>(q[k]));
          if (k >= i0 && k < i0 + B) qd[k].v.d[static_cast<std::size_t>(k - i0)] = 1.0;
          if (k == j) qd[k].d[0].v = 1.0;
        }
        modal::model::forward_kinematics(s, qd.data(), ts);
        const D v = modal::model::potential(s, ts, qd.data());
        for (int i = i0; i < std::min(n, i0 + B); ++i) H(i, j) = v.d[0].d[static_cast<std::size_t>(i - i0)];
      }
    benchmark::DoNotOptimize(H.data());
  }
  st.SetComplexityN(st.range(0));
}

BENCHMARK(Gradient)->RangeMultiplier(10)->Range(10, 1000)->Complexity()->Unit(benchmark::kMicrosecond);
BENCHMARK(Hessian)->RangeMultiplier(10)->Range(10, 1000)->Complexity()->Unit(benchmark::kMicrosecond);
BENCHMARK(MassMatrix)->RangeMultiplier(10)->Range(10, 1000)->Complexity()->Unit(benchmark::kMicrosecond);
BENCHMARK(SparseHessianNet)->Arg(58)->Arg(185)->Arg(580)->Complexity()->Unit(benchmark::kMillisecond);
BENCHMARK(SparseHessianNetFirst)->Arg(58)->Arg(185)->Arg(580)->Complexity()->Unit(benchmark::kMillisecond);
BENCHMARK(TensionMetricNet)->Arg(185)->Arg(580)->Unit(benchmark::kMillisecond);
BENCHMARK(TensionMetricNetFresh)->Arg(185)->Arg(580)->Unit(benchmark::kMillisecond);
BENCHMARK(HessianNestedAD)->RangeMultiplier(10)->Range(10, 100)->Complexity()->Unit(benchmark::kMicrosecond);

}  // namespace

BENCHMARK_MAIN();
