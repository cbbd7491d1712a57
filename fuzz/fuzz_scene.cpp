// libFuzzer target: the scene reader and the system built from it.
//
// Every input is a scene file's text. Reading it must either succeed or throw
// one of the documented errors (SceneError, with file:line:column, key and
// reason; ExpressionError inside parameter expressions); building the system
// and, for systems of at most 60 coordinates, evaluating V, ∇V, ∇∇V and M at
// the initial configuration must either succeed or throw NumericalError (a
// diagnosis in words). Anything else (another exception, a crash, a hang, a
// report of AddressSanitizer or UndefinedBehaviorSanitizer) is a finding.
//
// Build and run: scripts/test.sh does both (a clang build in build-fuzz,
// MODAL_FUZZ=ON, then a bounded run seeded with models/ and fuzz/scene.dict).
#include "modal/core.hpp"
#include "modal/expression.hpp"
#include "modal/scene.hpp"

#include <cstddef>
#include <cstdint>
#include <string_view>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  modal::Scene scene;
  try {
    // Generators bounded well below modal's limits: a mutated lattice size
    // would otherwise spend the run (and its memory limit) building millions
    // of particles, which is supported, not a finding.
    modal::SceneLimits limits;
    limits.particles = 20'000;
    limits.links = 2'000;
    scene = modal::parse_scene(text, "fuzz.toml", {}, limits);
  } catch (const modal::SceneError&) {
    return 0;
  } catch (const modal::ExpressionError&) {
    return 0;
  }
  try {
    const modal::System system = modal::build_system(scene);
    if (system.size() > 60) return 0;  // the evaluations below are for small systems: the fuzzer's time goes to reading
    modal::Workspace w(system);
    const modal::VectorX q = system.initial_configuration();
    (void)modal::potential(system, w, q);
    (void)modal::potential_gradient(system, w, q);
    (void)modal::potential_hessian(system, w, q);
    (void)modal::mass_matrix(system, w, q);
  } catch (const modal::SceneError&) {
  } catch (const modal::NumericalError&) {
  }
  return 0;
}
