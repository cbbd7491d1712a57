// embed — modal as a library, through the pipeline API (modal/pipeline.hpp):
// load a scene with parameter overrides, analyze it as `modal analyze` does,
// print ω² of every mode with its error estimate and the stability class, and
// optionally write the same JSON file as `modal analyze --json`.
//
//   embed SCENE.toml [NAME=VALUE ...] [--json FILE]
//   e.g. embed <prefix>/share/modal/models/double_pendulum.toml m2=2
//
// Output: one line per mode, "mode <k> omega2 <ω², rad²/s²> error <estimate>",
// then "stability <class>". Exit status: the CLI's (modal::exit_status): 0,
// 1 for a usage error, 2 for bad input, 4 for a numerical failure, with the
// CLI's message on stderr.
#include <modal/pipeline.hpp>

#include <cstdio>
#include <exception>
#include <sstream>
#include <string>
#include <vector>

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: %s SCENE.toml [NAME=VALUE ...] [--json FILE]\n", argv[0]);
    return static_cast<int>(modal::ExitStatus::usage);
  }
  std::vector<std::string> set;
  modal::Outputs outputs;
  for (int i = 2; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "--json" && i + 1 < argc)
      outputs.json = argv[++i];
    else
      set.push_back(arg);
  }
  try {
    modal::check_outputs(modal::Command::analyze, outputs, argv[1]);  // before computing, as the CLI does
    const modal::Model model = modal::load_model(argv[1], set);
    modal::AnalysisOptions options;  // the CLI's defaults: every mode (dense), exact derivatives
    const modal::Analysis analysis = modal::analyze(model, options);
    const modal::ModalResult& result = analysis.result();
    for (std::size_t k = 0; k < result.modes.size(); ++k)
      std::printf("mode %zu omega2 %.17g error %.2g\n", k + 1, result.modes[k].omega2,
                  result.modes[k].error_estimate);
    std::printf("stability %s\n", modal::to_string(result.stability));
    if (!outputs.json.empty()) {
      std::ostringstream table;  // the CLI's table, not shown: this program prints its own lines above
      modal::write_analysis(table, analysis, outputs);
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "%s\n", modal::error_message(e).c_str());
    return static_cast<int>(modal::exit_status(e));
  }
  return 0;
}
