// embed — modal as a library: load a scene, find the equilibrium nearest its
// initial configuration, linearize there and print ω² of every mode.
//
//   embed SCENE.toml        e.g. <prefix>/share/modal/models/double_pendulum.toml
//
// Output: one line per mode, "mode <k> omega2 <ω², rad²/s²> error <estimate>",
// then "stability <class>". Exit status 0, or 2 with the message on stderr.
#include <modal/equilibrium.hpp>
#include <modal/linearize.hpp>
#include <modal/modes.hpp>
#include <modal/scene.hpp>

#include <cstdio>
#include <exception>

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: %s SCENE.toml\n", argv[0]);
    return 1;
  }
  try {
    const modal::Scene scene = modal::load_scene(argv[1]);
    const modal::System system = modal::build_system(scene);
    const modal::Equilibrium eq = modal::find_equilibrium(system, system.initial_configuration());
    const modal::LinearModel model = modal::linearize(system, eq.q);
    const modal::ModalResult result = modal::solve_modes(model);
    for (std::size_t k = 0; k < result.modes.size(); ++k)
      std::printf("mode %zu omega2 %.17g error %.2g\n", k + 1, result.modes[k].omega2,
                  result.modes[k].error_estimate);
    std::printf("stability %s\n", modal::to_string(result.stability));
  } catch (const std::exception& e) {
    std::fprintf(stderr, "embed: %s\n", e.what());
    return 2;
  }
  return 0;
}
