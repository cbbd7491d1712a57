// Why modal compiles scene expressions itself instead of using GiNaC (the
// issue on kinematic maps asks to choose on measured speed and error
// messages). Both tools get the same job, the position z = −sqrt(l² − x² − y²)
// of the Foucault pendulum's bob and x = r cos θ sin φ of the spherical
// pendulum: parse the text, then evaluate value, gradient and Hessian at a
// point, as the core does at every Newton step. GiNaC's best case is used:
// derivatives differentiated symbolically once, outside the timed loop, then
// each evaluated by subs() + evalf(). modal evaluates its postfix code once
// with nested dual numbers (Dual<Dual<double, 2>, 2>).
// The program also prints both tools' messages for malformed input.
//
//   build/bench/bench_expression      (bench/expression_choice.sh writes results/expression_choice.md)
#include "modal/ad.hpp"
#include "modal/expression.hpp"

#include <benchmark/benchmark.h>
#include <ginac/ginac.h>

#include <array>
#include <cstdio>
#include <string>
#include <vector>

namespace {

struct Case {
  const char* text;
  const char* a;  // the two coordinates
  const char* b;
  double va, vb;
};
const Case cases[] = {{"-sqrt(l^2 - x^2 - y^2)", "x", "y", 0.5, -0.2}, {"r*cos(theta)*sin(phi)", "theta", "phi", 0.3, 2.5}};
const double l = 67, r = 1;

void ModalParse(benchmark::State& st) {
  const Case& c = cases[st.range(0)];
  const std::vector<std::string> vars{c.a, c.b, "l", "r"};
  for (auto _ : st) benchmark::DoNotOptimize(modal::Expression::parse(c.text, vars));
}

void GinacParse(benchmark::State& st) {
  const Case& c = cases[st.range(0)];
  GiNaC::symbol a(c.a), b(c.b), ls("l"), rs("r");
  GiNaC::symtab table{{c.a, a}, {c.b, b}, {"l", ls}, {"r", rs}};
  for (auto _ : st) {
    GiNaC::parser reader(table, true);
    benchmark::DoNotOptimize(reader(c.text));
  }
}

void ModalHessian(benchmark::State& st) {
  const Case& c = cases[st.range(0)];
  const modal::Expression e = modal::Expression::parse(c.text, {c.a, c.b, "l", "r"});
  using I = modal::Dual<double, 2>;
  using O = modal::Dual<I, 2>;
  double sink = 0;
  for (auto _ : st) {
    std::array<O, 4> v{O(I(c.va)), O(I(c.vb)), O(l), O(r)};
    v[0].v.d[0] = 1;
    v[1].v.d[1] = 1;
    v[0].d[0] = I(1.0);
    v[1].d[1] = I(1.0);
    const O f = e.evaluate<O>(v.data());
    sink += f.v.v + f.v.d[0] + f.v.d[1] + f.d[0].d[0] + f.d[0].d[1] + f.d[1].d[1];
  }
  benchmark::DoNotOptimize(sink);
}

void GinacHessian(benchmark::State& st) {
  const Case& c = cases[st.range(0)];
  GiNaC::symbol a(c.a), b(c.b), ls("l"), rs("r");
  GiNaC::symtab table{{c.a, a}, {c.b, b}, {"l", ls}, {"r", rs}};
  GiNaC::parser reader(table, true);
  const GiNaC::ex f = reader(c.text);
  const std::vector<GiNaC::ex> parts{f, f.diff(a), f.diff(b), f.diff(a).diff(a), f.diff(a).diff(b), f.diff(b).diff(b)};
  double sink = 0;
  for (auto _ : st) {
    const GiNaC::exmap point{{a, c.va}, {b, c.vb}, {ls, l}, {rs, r}};
    for (const GiNaC::ex& p : parts) sink += GiNaC::ex_to<GiNaC::numeric>(p.subs(point).evalf()).to_double();
  }
  benchmark::DoNotOptimize(sink);
}

void print_messages() {
  const char* bad[] = {"x*cos(y", "x*coz(y)", "x*cos(q)", "x**2 +* y"};
  std::printf("Messages for malformed expressions (variables x, y):\n\n");
  for (const char* text : bad) {
    std::printf("  \"%s\"\n", text);
    try {
      (void)modal::Expression::parse(text, {"x", "y"});
      std::printf("    modal: accepted\n");
    } catch (const modal::ExpressionError& e) {
      std::printf("    modal: at %d: %s\n", e.position() + 1, e.what());
    }
    GiNaC::symbol x("x"), y("y");
    GiNaC::symtab table{{"x", x}, {"y", y}};
    for (const bool strict : {false, true}) {
      try {
        GiNaC::parser reader(table, strict);
        (void)reader(text);
        std::printf("    GiNaC%s: accepted\n", strict ? " (strict)" : "");
      } catch (const std::exception& e) {
        std::string m = e.what();
        if (const auto cut = m.find('\n'); cut != std::string::npos) m.resize(cut);
        std::printf("    GiNaC%s: %s\n", strict ? " (strict)" : "", m.c_str());
      }
    }
  }
  std::printf("\n");
}

}  // namespace

BENCHMARK(ModalParse)->DenseRange(0, 1)->Unit(benchmark::kMicrosecond);
BENCHMARK(GinacParse)->DenseRange(0, 1)->Unit(benchmark::kMicrosecond);
BENCHMARK(ModalHessian)->DenseRange(0, 1)->Unit(benchmark::kMicrosecond);
BENCHMARK(GinacHessian)->DenseRange(0, 1)->Unit(benchmark::kMicrosecond);

int main(int argc, char** argv) {
  print_messages();
  benchmark::Initialize(&argc, argv);
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
