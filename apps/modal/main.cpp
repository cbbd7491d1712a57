// modal — the command-line program (docs/design.md, "Command line").
//
// Only the grammar of the command line: each subcommand's options are read
// into the options values of modal/pipeline.hpp, which computes and writes
// everything. Exit statuses: 0 success, 1 usage, 2 bad scene or input,
// 3 unstable under --require-stable, 4 numerical failure.
#include "memory_policy.hpp"
#include "modal/pipeline.hpp"
#if defined(MODAL_DISTRIBUTED)
#include "modal/distributed.hpp"
#endif

#include <CLI/CLI.hpp>

#include <algorithm>
#include <atomic>
#include <cctype>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <csignal>
#include <iostream>
#include <limits>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include <cerrno>
#include <climits>
#include <cstring>

#include <signal.h>
#include <unistd.h>

namespace {

// A library that ends the process with exit() in the middle of a computation
// (libgomp, CHOLMOD's threads, when it cannot start a thread: "libgomp:
// Thread creation failed", under a memory or thread limit) would leave exit
// status 1, which means a usage error here, and the outputs' temporaries
// behind. While main runs, such an exit is reported as a failed computation
// (exit status 4); main's own returns pass untouched.
std::atomic<bool> main_running{false};

void library_ended_the_process() {
  if (!main_running.load()) return;
  modal_program::end_now(
      "modal: a library this computation uses ended the process before the computation finished "
      "(its own message, if any, is above)\n");
}

// OpenBLAS 0.3.21 raises SIGINT itself when it cannot start its threads
// (blas_thread_init), which the handler of remove_output_temporaries_on_signals
// would re-raise as an interrupt (status 130). A SIGINT the process sent
// itself while main runs is that library's way out; any other (the
// terminal's, another process's) goes on to the previous handler.
struct sigaction previous_interrupt {};

void interrupt(int signal, siginfo_t* info, void* context) {
  if (info != nullptr && info->si_code == SI_TKILL && info->si_pid == getpid()) library_ended_the_process();
  if ((previous_interrupt.sa_flags & SA_SIGINFO) != 0) {
    previous_interrupt.sa_sigaction(signal, info, context);
  } else if (previous_interrupt.sa_handler == SIG_DFL) {
    std::signal(signal, SIG_DFL);
    std::raise(signal);
  } else if (previous_interrupt.sa_handler != SIG_IGN) {
    previous_interrupt.sa_handler(signal);
  }
}

void library_interrupts_end_the_process() {
  struct sigaction action {};
  action.sa_sigaction = interrupt;
  action.sa_flags = SA_SIGINFO | SA_RESTART;
  sigemptyset(&action.sa_mask);
  sigaction(SIGINT, &action, &previous_interrupt);
}

struct MainRunning {
  MainRunning() {
    if (std::atexit(library_ended_the_process) == 0) main_running = true;
  }
  ~MainRunning() { main_running = false; }
  MainRunning(const MainRunning&) = delete;
  MainRunning& operator=(const MainRunning&) = delete;
};

// Option checks whose messages read as sentences ("--modes must be a whole
// number ≥ 1, got 0"), not CLI11's "Value 0 not in range 0 to 1.79e308".
CLI::Validator at_least(double low, bool whole = true) {
  return CLI::Validator(
      [low, whole](std::string& text) -> std::string {
        char* end = nullptr;
        const double v = std::strtod(text.c_str(), &end);
        const bool ok = end != text.c_str() && *end == '\0' && std::isfinite(v) && v >= low &&
                        (!whole || v == std::floor(v));
        if (ok) return {};
        return std::string("must be ") + (whole ? "a whole number" : "a number") + " ≥ " + CLI::detail::to_string(low) +
               ", got '" + text + "'";
      },
      "");
}
// A number > 0, and at most `most` when that is finite.
CLI::Validator positive(double most = std::numeric_limits<double>::infinity()) {
  return CLI::Validator(
      [most](std::string& text) -> std::string {
        char* end = nullptr;
        const double v = std::strtod(text.c_str(), &end);
        if (end != text.c_str() && *end == '\0' && std::isfinite(v) && v > 0 && v <= most) return {};
        if (std::isfinite(most)) return "must be a number above 0 and at most " + CLI::detail::to_string(most) + ", got '" + text + "'";
        return "must be a finite number > 0, got '" + text + "'";
      },
      "");
}
CLI::Validator between(double low, double high, bool whole = false) {
  return CLI::Validator(
      [=](std::string& text) -> std::string {
        char* end = nullptr;
        const double v = std::strtod(text.c_str(), &end);
        if (end != text.c_str() && *end == '\0' && v >= low && v <= high && (!whole || v == std::floor(v))) return {};
        return std::string("must be ") + (whole ? "a whole number" : "a number") + " from " +
               CLI::detail::to_string(low) + " to " + CLI::detail::to_string(high) + ", got '" + text + "'";
      },
      "");
}

// A number in [low, high): "must be a number from 1e-15 up to (not
// including) 1".
CLI::Validator from_below(double low, double high) {
  return CLI::Validator(
      [=](std::string& text) -> std::string {
        char* end = nullptr;
        const double v = std::strtod(text.c_str(), &end);
        if (end != text.c_str() && *end == '\0' && v >= low && v < high) return {};
        return "must be a number from " + CLI::detail::to_string(low) + " up to (not including) " +
               CLI::detail::to_string(high) + ", got '" + text + "'";
      },
      "");
}

struct SceneArgs {
  std::string file;
  std::vector<std::string> sets;
  bool allow_outside_data = false;
  double max_memory = 0;  // bytes (modal::SceneLimits::memory); 0: not given
  std::string format = "auto";
};

void add_format_option(CLI::App* cmd, std::string& format) {
  cmd->add_option("--format", format,
                  "how to read the scene file: toml, mjcf (MuJoCo XML), urdf, or auto (by its extension .toml, "
                  ".xml, .urdf, then its content)")
      ->capture_default_str()
      ->check(CLI::IsMember({"auto", "toml", "mjcf", "urdf"}));
}

void add_scene_options(CLI::App* cmd, SceneArgs& s) {
  cmd->add_option("SCENE", s.file,
                  "scene file: TOML (docs/design.md \"Scene format\"), MJCF or URDF (\"Importing MJCF and URDF\")")
      ->required();
  cmd->add_option("--set", s.sets, "override a parameter: NAME=VALUE (VALUE may be an expression)")
      ->type_name("N=V")
      ->multi_option_policy(CLI::MultiOptionPolicy::TakeAll);
  cmd->add_flag("--allow-outside-data", s.allow_outside_data,
                "read data files (a network's CSV) from anywhere, not only from the scene file's directory and below");
  // Read once, with the command line: a size modal::parse_memory_size reads (4G, 512M, bytes).
  cmd->add_option_function<std::string>(
         "--max-memory",
         [&s](const std::string& text) {
           try {
             s.max_memory = modal::parse_memory_size(text);
           } catch (const modal::InputError&) {
             throw CLI::ValidationError("--max-memory", "must be a size such as 4G, 512M or a number of bytes above "
                                                        "0, got '" + text + "'");
           }
         },
         "memory the scene and the command may use, e.g. 4G or 512M (default: what the machine has "
         "available); larger work is refused before it starts")
      ->type_name("SIZE");
  add_format_option(cmd, s.format);
}

modal::Model load(const SceneArgs& s) {
  modal::SceneLimits limits;
  limits.allow_outside_data = s.allow_outside_data;
  limits.memory = s.max_memory;
  return modal::load_model(s.file, s.sets, limits, *modal::parse_scene_format(s.format));
}

// The scene, with the outputs checked before it is read (against the scene
// file) and after (against the data files it read too): nothing is computed
// for outputs that cannot be written or would replace an input.
modal::Model load_checked(const SceneArgs& s, modal::Command command, const modal::Outputs& outputs,
                          bool extrapolate = false) {
  modal::check_outputs(command, outputs, s.file, extrapolate);
  modal::Model model = load(s);
  modal::check_outputs_spare_data(command, outputs, model.scene.data_files, extrapolate);
  return model;
}

void add_backend_option(CLI::App* cmd, std::string& backend, const std::string& command) {
  cmd->add_option("--backend", backend,
                  "serial (this process), or petsc: the distributed backend for scenes of particles and springs, "
                  "over the ranks of mpirun (mpirun -np N modal " + command + " SCENE --backend petsc)")
      ->check(CLI::IsMember({"serial", "petsc"}))
      ->capture_default_str();
}

template <class Enum>
Enum choose(const std::string& word, std::initializer_list<Enum> values) {
  for (Enum v : values)
    if (word == modal::to_string(v)) return v;
  return *values.begin();  // CLI11's IsMember checked the word
}

using Seconds = std::vector<std::pair<std::string, double>>;
double since(std::chrono::steady_clock::time_point& last) {
  const auto now = std::chrono::steady_clock::now();
  const double s = std::chrono::duration<double>(now - last).count();
  last = now;
  return s;
}

#if defined(MODAL_DISTRIBUTED)
// The scene of a distributed request as the command line gives it.
template <class Request>
void set_scene(Request& request, const SceneArgs& s) {
  request.scene_file = s.file;
  request.sets = s.sets;
  request.limits.allow_outside_data = s.allow_outside_data;
  request.limits.memory = s.max_memory;
  request.format = *modal::parse_scene_format(s.format);
}
#endif

#if !defined(MODAL_DISTRIBUTED)
// `analyze --backend petsc` (and sweep, equilibria) in the program `modal`: replaced (execv, same
// process, same arguments and environment, so an mpirun rank stays one) by the
// program modal-mpi beside it, which carries MPI, PETSc and SLEPc; `modal`
// itself loads none of them. Returns only when that fails: the exit status.
int run_distributed_program(char** argv) {
#if defined(MODAL_MPI_PROGRAM)
  char self[PATH_MAX];
  const ssize_t length = readlink("/proc/self/exe", self, sizeof self - 1);
  std::string path = length > 0 ? std::string(self, static_cast<std::size_t>(length)) : std::string(argv[0]);
  path = path.substr(0, path.find_last_of('/') + 1) + MODAL_MPI_PROGRAM;
  execv(path.c_str(), argv);
  std::cerr << "modal: --backend petsc: cannot run " << path << " (" << std::strerror(errno)
            << "); it is installed beside modal when modal is built with MODAL_WITH_PETSC\n";
#else
  (void)argv;
  std::cerr << "modal: --backend petsc: this modal was built without the distributed backend (configure with "
               "-DMODAL_WITH_PETSC=ON, which needs PETSc, SLEPc and MPI: scripts/setup-debian.sh installs them)\n";
#endif
  return static_cast<int>(modal::ExitStatus::bad_input);
}
#endif

// Edit distance between two option names (insertions, deletions,
// substitutions), for "did you mean".
std::size_t edit_distance(const std::string& a, const std::string& b) {
  std::vector<std::size_t> row(b.size() + 1);
  for (std::size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    std::size_t diagonal = row[0];
    row[0] = i;
    for (std::size_t j = 1; j <= b.size(); ++j) {
      const std::size_t above = row[j];
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, diagonal + (a[i - 1] == b[j - 1] ? 0 : 1)});
      diagonal = above;
    }
  }
  return row[b.size()];
}

// The words of `text` that look like long option names ("--modes").
std::vector<std::string> option_words(const std::string& text) {
  std::vector<std::string> words;
  for (std::size_t at = text.find("--"); at != std::string::npos; at = text.find("--", at + 2)) {
    std::size_t end = at + 2;
    while (end < text.size() && (std::isalnum(static_cast<unsigned char>(text[end])) != 0 || text[end] == '-')) ++end;
    if (end > at + 2) words.push_back(text.substr(at, end - at));
    at = end - 2;
  }
  return words;
}

// A usage error as a sentence naming the command ("modal analyze: --modes:
// ..."), CLI11's own texts rewritten where they are not sentences ("Could not
// convert: --modes = <300 digits>"), arguments shown escaped and cut to 40
// characters. Then, instead of the command's whole help (40–60 lines that
// bury the sentence): the help line of the option it names, or for an
// option the command does not have the nearest names it has ("did you
// mean"), the command's usage line and where the whole help is.
std::string usage_failure(const CLI::App* app, const CLI::Error& e) {
  std::string what = e.what();
  constexpr std::string_view convert = "Could not convert: ";
  if (what.starts_with(convert)) {
    const std::string rest = what.substr(convert.size());
    if (const auto eq = rest.find(" = "); eq != std::string::npos) {
      std::string value = rest.substr(eq + 3);
      if (value.size() > 40) value = value.substr(0, 37) + "...";
      what = rest.substr(0, eq) + ": '" + value + "' is not a value it takes (a number within its range)";
    }
  } else if (what.starts_with("modal: ")) {
    what.erase(0, 7);
  }
  // CLI11's other texts that are not sentences of this program's style.
  if (const auto in = what.find(" not in {"); in != std::string::npos && what.ends_with("}")) {
    std::string names = what.substr(in + 9, what.size() - in - 10);
    for (std::size_t comma = names.find(','); comma != std::string::npos; comma = names.find(',', comma + 2))
      names.replace(comma, 1, ", ");
    const std::size_t colon = what.rfind(": ", in);
    const std::size_t start = colon == std::string::npos ? 0 : colon + 2;
    what = what.substr(0, start) + "'" + what.substr(start, in - start) + "' is not one of " + names;
  }
  for (const std::string_view unexpected : {"The following argument was not expected: ",
                                            "The following arguments were not expected: "})
    if (what.starts_with(unexpected)) {
      // CLI11 lists them last first: in the order given.
      std::vector<std::string> given;
      std::istringstream words(what.substr(unexpected.size()));
      for (std::string w; words >> w;) given.insert(given.begin(), w);
      what = "not an option or argument of this command:";
      for (const std::string& w : given) what += " " + w;
    }
  // "--modes: At Most 1 required but received 2", "--modes: 1 required INT missing".
  if (const auto at = what.find(": At Most 1 required but received "); at != std::string::npos)
    what = what.substr(0, at) + ": given " + what.substr(at + 34) + " times; give it once";
  if (const auto at = what.find(": 1 required "); at != std::string::npos && what.ends_with(" missing"))
    what = what.substr(0, at) + ": needs a value (" + what.substr(at + 13, what.size() - at - 13 - 8) + ")";
  const bool top = !app->get_subcommands({}).empty();  // the program itself: a command missing or misspelt
  std::vector<std::string> rest = top ? app->remaining() : std::vector<std::string>{};
  if (top && !rest.empty() && !rest.front().starts_with("-")) {
    what = "'" + rest.front() + "' is not a command of modal";
    for (const CLI::App* sub : app->get_subcommands({}))
      if (edit_distance(rest.front(), sub->get_name()) <= 2) what += "; did you mean " + sub->get_name() + "?";
  } else if (top && what == "A subcommand is required") {
    what = "a command is required: one of those below";
  }
  std::string command = "modal";
  if (app->get_parent() != nullptr) command += " " + app->get_name();
  std::string out = command + ": " + modal::abridged(modal::printable(what)) + "\n";
  const auto formatter = std::dynamic_pointer_cast<CLI::Formatter>(app->get_formatter());
  for (const std::string& word : option_words(what)) {
    if (word == "--help") continue;
    if (const CLI::Option* option = app->get_option_no_throw(word); option != nullptr) {
      if (formatter) out += formatter->make_option(option, false);
      continue;
    }
    std::vector<std::string> near;
    for (const CLI::Option* option : app->get_options())
      for (const std::string& name : option->get_lnames())
        if (edit_distance(word, "--" + name) <= std::max<std::size_t>(2, word.size() / 4)) near.push_back("--" + name);
    if (!near.empty()) {
      out += "did you mean";
      for (std::size_t i = 0; i < near.size(); ++i) out += (i == 0 ? " " : i + 1 == near.size() ? " or " : ", ") + near[i];
      out += "?\n";
    }
  }
  if (top && formatter) {
    out += formatter->make_usage(app, command) + formatter->make_subcommands(app, CLI::AppFormatMode::Normal);
  } else if (formatter) {
    out += formatter->make_usage(app, command);
  }
  out += "Run '" + command + " --help' for every option and its meaning.\n";
  return out;
}

}  // namespace

// A function try block: memory refused while the command line is being set
// up (under a small address-space limit) is reported as any lack of memory.
int main(int argc, char** argv) try {
#if defined(MODAL_DISTRIBUTED)
  const modal::DistributedSession session;  // MPI, PETSc and SLEPc for the whole process
#endif
  modal_program::set_memory_policy();
  const MainRunning running;  // from here, a library's exit() is a failed computation
  modal::remove_output_temporaries_on_signals();  // an interrupt leaves the previous outputs as they were
  library_interrupts_end_the_process();
  // A closed pipe (modal … | head) is a failed write, reported with exit
  // status 2 (check_written), not a death by SIGPIPE.
  std::signal(SIGPIPE, SIG_IGN);
  CLI::App app{"modal — linearization and modal analysis of Lagrangian mechanical systems", "modal"};
  // Set before adding subcommands: they copy it. On a usage error, print the
  // message and the help of the command that failed.
  app.failure_message(usage_failure);
  app.set_version_flag("--version", std::string("modal ") + MODAL_VERSION);
  app.require_subcommand(1);
  bool quiet = false;
  app.add_flag("--quiet,-q", quiet, "no progress bar on stderr (errors, warnings and --timing are still printed)");
  app.fallthrough();  // --quiet after the command's name too
  app.footer(
      "Exit status: 0 success, 1 usage, 2 bad scene or input, 3 unstable under analyze --require-stable, "
      "4 numerical failure.\n"
      "Environment: MODAL_HUGE_PAGES=1 backs the working memory with transparent huge pages (may pay on bare "
      "metal; slower on virtual machines that hand freed memory back to their host); MODAL_POPULATE=0 leaves large blocks to fault in page by page.\n");

  // --- analyze ---
  SceneArgs analyze_scene;
  modal::AnalysisOptions ao;
  modal::Outputs analyze_out;
  std::string at, solver = "auto", dense_solver = "auto", derivatives = "exact", large_equilibrium = "newton";
  std::string backend = "serial";
  double shift = 0;
  bool require_stable = false, timing = false;
  CLI::App* analyze = app.add_subcommand(
      "analyze", "find the equilibrium nearest the initial configuration (or --at), linearize, report modes");
  add_scene_options(analyze, analyze_scene);
  analyze->add_option("--modes", ao.modes, "number of lowest modes to report (default: all)")->check(at_least(1));
  CLI::Option* at_option =
      analyze->add_option("--at", at, "analyze the equilibrium at this point: q1,q2,... (one value per coordinate)");
  analyze->add_option("--csv", analyze_out.csv,
                      "write PREFIX_modes.csv, PREFIX_shapes.csv, PREFIX_equilibria.csv (with --energy also "
                      "PREFIX_energy.csv, PREFIX_participation.csv)")
      ->type_name("PREFIX");
  analyze->add_flag("--energy", ao.energy,
                    "each mode's kinetic and potential energy by body, spring and term, and the effective masses "
                    "of base translation (text, CSV, JSON)");
  analyze->add_option("--json", analyze_out.json, "write the whole result as JSON")->type_name("FILE");
  analyze
      ->add_option("--report", analyze_out.report,
                   "write one self-contained HTML page (no network needed to open it): scene, equilibrium, "
                   "stability, the mode table, each mode animated over the equilibrium (or its shape as a bar "
                   "chart), with --energy the energy shares and participation; the name must end in .html or .htm")
      ->type_name("FILE.html");
  analyze->add_flag("--require-stable", require_stable,
                    "exit with status 3 if the equilibrium is unstable (divergence or flutter)");
  analyze->add_flag("--timing", timing, "print the wall time of each stage and the peak memory on stderr");
  analyze
      ->add_option("--solver", solver,
                   "eigen-solver: dense (all modes), sparse (the --modes lowest, default 10, by shift-invert "
                   "Lanczos with a sparse Cholesky), tree (the same without matrices, by recursions over a tree of "
                   "hinges and slides: long chains), or auto: sparse above " +
                       std::to_string(modal::large_system_coordinates) +
                       " coordinates when the scene has no dampers, follower loads, constraints, rotating frame or "
                       "map, tree there for long chains (dense where tree cannot factor M and dense fits)")
      ->check(CLI::IsMember({"auto", "dense", "sparse", "tree"}))
      ->capture_default_str();
  add_backend_option(analyze, backend, "analyze");
  CLI::Option* shift_option = analyze->add_option(
      "--shift", shift, "sparse solver: find the modes with ω² nearest this shift (rad²/s²; default: the lowest)");
  analyze->add_option("--tol", ao.tolerance, "sparse solver: relative convergence tolerance")
      ->check(positive())
      ->capture_default_str();
  analyze
      ->add_option("--large-equilibrium", large_equilibrium,
                   "equilibrium of a scene above " + std::to_string(modal::large_system_coordinates) +
                       " coordinates: newton (truncated Newton from the start with the sparse Hessian; L-BFGS if it "
                       "stalls) or lbfgs (L-BFGS down to 1e-4 of the starting gradient first, then Newton)")
      ->check(CLI::IsMember({"newton", "lbfgs"}))
      ->capture_default_str();
  analyze
      ->add_option("--dense-solver", dense_solver,
                   "dense symmetric eigen-solver: eigen (self-adjoint QR), lapack (dsygvd, divide and conquer), or "
                   "auto: lapack from " + std::to_string(modal::lapack_threshold) + " coordinates")
      ->check(CLI::IsMember({"auto", "eigen", "lapack"}))
      ->capture_default_str();
  analyze
      ->add_option("--derivatives", derivatives,
                   "how K (and G) are differentiated: exact (automatic differentiation), central, forward "
                   "(differences of the exact forces) or complex-step; dense path only")
      ->check(CLI::IsMember({"exact", "central", "forward", "complex-step"}))
      ->capture_default_str();
  analyze
      ->add_option("--step", ao.step_factor,
                   "difference step as a factor of max(|q|, 1 rad or the length scale) (default: sqrt(eps) "
                   "forward, cbrt(eps) central, 1e-20 complex-step; at most 0.1)")
      ->check(positive(modal::max_step_factor));
  analyze
      ->add_option("--eq-tol", ao.equilibrium_tolerance,
                   "equilibrium: accepted relative residual of |grad V - Q|, as a whole and on each coordinate "
                   "(against the forces acting, beyond the rounding level of the springs' forces)")
      ->check(between(1e-16, 1e-2))
      ->capture_default_str();
  analyze->add_option("--export-matrices", analyze_out.matrices,
                      "write M, K (and D, G where present) at the equilibrium as Matrix Market files into DIR")
      ->type_name("DIR");

  // --- equilibria ---
  SceneArgs equilibria_scene;
  modal::EquilibriumOptions eo;
  modal::Outputs equilibria_out;
  CLI::App* equilibria =
      app.add_subcommand("equilibria", "enumerate equilibria with their stability and Morse index");
  add_scene_options(equilibria, equilibria_scene);
  equilibria
      ->add_option("--starts", eo.starts,
                   "number of deterministic search starts (default: 64 up to 30 coordinates, then 64·(30/n)², at least 2)")
      ->check(at_least(0));
  std::string equilibria_backend = "serial";
  add_backend_option(equilibria, equilibria_backend, "equilibria");
  equilibria->add_option("--csv", equilibria_out.csv, "write the equilibria table as CSV")->type_name("FILE");
  equilibria->add_option("--json", equilibria_out.json, "write all equilibria and their modes as JSON")
      ->type_name("FILE");
  equilibria
      ->add_option("--report", equilibria_out.report,
                   "write one self-contained HTML page: the equilibria with their stability and energy, and each "
                   "one's frequency table; the name must end in .html or .htm")
      ->type_name("FILE.html");

  // --- sweep ---
  SceneArgs sweep_scene;
  std::vector<std::string> varies;
  modal::SweepStudyOptions sweep_options;
  modal::Outputs sweep_out;
  CLI::App* sweep = app.add_subcommand(
      "sweep", "frequencies and stability along a parameter, critical values refined; two --vary: a stability map");
  add_scene_options(sweep, sweep_scene);
  sweep
      ->add_option("--vary", varies,
                   "vary a parameter over COUNT evenly spaced values (COUNT >= 2) or over a list of values "
                   "(N=10,20,40); give it twice for a map")
      ->type_name("N=FROM:TO:COUNT|N=V1,V2,...")
      ->required()
      ->multi_option_policy(CLI::MultiOptionPolicy::TakeAll);
  std::string sweep_backend = "serial";
  add_backend_option(sweep, sweep_backend, "sweep");
  sweep
      ->add_option("--csv", sweep_out.csv,
                   "one --vary: one row per point and mode, critical values to FILE_critical.csv; two: one row per "
                   "grid point")
      ->type_name("FILE");
  sweep
      ->add_option("--modes", sweep_options.modes,
                   "number of lowest modes per point in the CSV (default: all), and extrapolated (default: 3)")
      ->check(at_least(1));
  sweep->add_flag("--extrapolate", sweep_options.extrapolate,
                  "the parameter is a number of links or elements (integers, at least 3 values): report each mode's "
                  "observed order of convergence and its Richardson-extrapolated frequency with an error estimate; "
                  "with --csv also FILE_convergence.csv and FILE_extrapolation.csv");
  sweep
      ->add_option("--report", sweep_out.report,
                   "write one self-contained HTML page: the branches against the parameter, the root locus, a "
                   "Campbell diagram when the parameter turns the scene's frame, the critical values; with "
                   "--extrapolate the convergence plot; two --vary: the coloured stability map; the name must end "
                   "in .html")
      ->type_name("FILE.html");

  // --- check ---
  SceneArgs check_scene;
  bool check_all = false;
  CLI::App* check = app.add_subcommand("check", "validate the scene and print a summary");
  add_scene_options(check, check_scene);
  check->add_flag("--all", check_all, "list every body, coordinate and spring (default: the first 100 of each)");

  // --- simulate ---
  SceneArgs simulate_scene;
  modal::SimulationRequest sim;
  modal::Outputs simulate_out;
  std::string simulate_at, simulate_velocity;
  double simulate_interval = 0;
  CLI::App* simulate = app.add_subcommand(
      "simulate",
      "integrate the nonlinear equations of motion from the initial configuration (or --at) and write the "
      "trajectory with its energy as CSV");
  add_scene_options(simulate, simulate_scene);
  simulate->add_option("--duration", sim.duration, "end time of the motion, s")
      ->type_name("T")
      ->required()
      ->check(positive());
  CLI::Option* simulate_at_option = simulate->add_option(
      "--at", simulate_at, "initial configuration q1,q2,... (taken as given; default: the scene's initial values)");
  CLI::Option* simulate_velocity_option =
      simulate->add_option("--velocity", simulate_velocity, "initial velocities v1,v2,... (default: 0)");
  CLI::Option* simulate_interval_option =
      simulate->add_option("--interval", simulate_interval, "spacing of the output samples, s (default: T/1000)")
          ->type_name("DT")
          ->check(positive());
  simulate
      ->add_option("--tolerance", sim.tolerance,
                   "error bound per integration step, relative and absolute (default: " +
                       CLI::detail::to_string(modal::SimulationOptions{}.tolerance) + ")")
      ->type_name("TOL")
      ->check(from_below(modal::min_simulation_tolerance, 1));
  simulate->add_option("--csv", simulate_out.csv, "write the trajectory to FILE instead of standard output")
      ->type_name("FILE");
  simulate
      ->add_option("--report", simulate_out.report,
                   "write one self-contained HTML page: the coordinates and the energy error against time; the "
                   "name must end in .html or .htm")
      ->type_name("FILE.html");

  // --- amplitude ---
  SceneArgs amplitude_scene;
  modal::AmplitudeRequest amp;
  modal::Outputs amplitude_out;
  std::string amplitude_at;
  CLI::App* amplitude = app.add_subcommand(
      "amplitude",
      "release a mode from rest at growing amplitudes, integrate the nonlinear equations and measure its frequency: "
      "where does the linear model stop holding?");
  add_scene_options(amplitude, amplitude_scene);
  amplitude->add_option("--mode", amp.mode, "the mode (1 = the lowest)")->capture_default_str()->check(at_least(1));
  CLI::Option* amplitude_at_option = amplitude->add_option(
      "--at", amplitude_at, "the equilibrium near this point: q1,q2,... (default: the initial one)");
  amplitude
      ->add_option("--amplitudes", amp.options.amplitudes,
                   "amplitudes to measure, ascending, in the unit of the shape's largest component (rad or m)")
      ->delimiter(',')
      ->check(positive());
  amplitude
      ->add_option("--max-amplitude", amp.options.max_amplitude,
                   "largest amplitude of the default scan (default: 2.5 rad, or half the length scale)")
      ->check(positive());
  amplitude->add_option("--points", amp.options.points, "amplitudes in the default scan (log-spaced)")
      ->capture_default_str()
      ->check(between(2, 1000, true));
  amplitude->add_option("--cycles", amp.options.cycles, "periods measured per amplitude")
      ->capture_default_str()
      ->check(between(1, 10000, true));
  amplitude->add_option("--tolerance", amp.options.tolerance, "integrator error bound per step")
      ->capture_default_str()
      ->check(between(1e-15, 1e-3));
  amplitude->add_option("--csv", amplitude_out.csv, "write the scan as CSV")->type_name("FILE");
  amplitude
      ->add_option("--report", amplitude_out.report,
                   "write one self-contained HTML page: the period ratio and the departure from the linear "
                   "frequency against amplitude, the 1 % and 10 % amplitudes marked; the name must end in .html or .htm")
      ->type_name("FILE.html");

  // --- convert ---
  std::string convert_file, convert_output, convert_format = "auto";
  CLI::App* convert = app.add_subcommand(
      "convert", "write an MJCF or URDF model as the equivalent TOML scene (to standard output, or -o FILE)");
  convert->add_option("SCENE", convert_file, "the model file (MJCF, URDF; a TOML scene is copied)")->required();
  convert->add_option("-o,--output", convert_output, "write the TOML scene to FILE")->type_name("FILE");
  add_format_option(convert, convert_format);
  // Status 3 is analyze's alone (--require-stable).
  for (CLI::App* command : {equilibria, sweep, check, simulate, amplitude, convert})
    command->footer("Exit status: 0 success, 1 usage, 2 bad scene or input, 4 numerical failure.\n");

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    CLI::App* where = &app;
    for (CLI::App* sub : app.get_subcommands()) where = sub;
    return where->exit(e) == 0 ? 0 : static_cast<int>(modal::ExitStatus::usage);
  }

  try {
    auto clock = std::chrono::steady_clock::now();
    if ((*analyze && backend == "petsc") || (*equilibria && equilibria_backend == "petsc") ||
        (*sweep && sweep_backend == "petsc")) {
#if defined(MODAL_DISTRIBUTED)
      if (*equilibria) {
        // docs/cluster.md: the survey analyzes every equilibrium it finds
        // with all its modes (dense), which does not fit a scene for the
        // distributed backend.
        if (session.rank() == 0)
          std::cerr << "modal: equilibria --backend petsc: the survey of equilibria solves every equilibrium it "
                       "finds for all its modes with dense matrices, which scenes for the distributed backend do "
                       "not fit; use analyze --backend petsc from a chosen configuration (--set), or sweep "
                       "--backend petsc along a parameter\n";
        return static_cast<int>(modal::ExitStatus::bad_input);
      }
      if (*sweep) {
        modal::DistributedSweepRequest request;
        set_scene(request, sweep_scene);
        request.varies = varies;
        request.options = sweep_options;
        request.outputs = sweep_out;
        return modal::sweep_distributed(request, std::cout, std::cerr);
      }
      modal::DistributedRequest request;
      set_scene(request, analyze_scene);
      if (shift_option->count()) ao.shift = shift;
      request.options = ao;
      request.outputs = analyze_out;
      request.timing = timing;
      request.require_stable = require_stable;
      return modal::analyze_distributed(request, std::cout, std::cerr);
#else
      return run_distributed_program(argv);
#endif
    }
    if (*analyze) {
      analyze_out.energy = ao.energy;
      ao.drawing = !analyze_out.report.empty();
      const modal::Model model = load_checked(analyze_scene, modal::Command::analyze, analyze_out);
      Seconds seconds{{"parse+build", since(clock)}};
      ao.solver = choose(solver, {modal::SolverChoice::automatic, modal::SolverChoice::dense,
                                  modal::SolverChoice::sparse, modal::SolverChoice::tree});
      ao.dense_solver =
          choose(dense_solver, {modal::DenseSolver::automatic, modal::DenseSolver::eigen, modal::DenseSolver::lapack});
      ao.derivatives = *modal::parse_derivative_method(derivatives);
      if (large_equilibrium == "lbfgs") ao.large_equilibrium = modal::LargeEquilibriumMethod::lbfgs;
      if (shift_option->count()) ao.shift = shift;
      if (at_option->count()) ao.at = modal::parse_coordinates(model.system, "--at", at);
      std::optional<modal::Analysis> analysis;
      {
        modal::ProgressBar bar("equilibrium", !quiet);  // large scenes: the residual's digits (silent when not a terminal)
        ao.progress = [&bar](int done, int total) {
          bar.update(done, total);
          if (done >= total) bar.finish();  // converged: the eigen-solution follows
        };
        analysis.emplace(modal::analyze(model, ao));
      }
      const modal::Analysis& a = *analysis;
      seconds.insert(seconds.end(), a.timings.begin(), a.timings.end());
      since(clock);
      modal::write_analysis(std::cout, a, analyze_out);
      seconds.emplace_back("report", since(clock));
      if (timing) modal::print_timings(std::cerr, seconds);
      if (require_stable && a.unstable()) {
        std::cerr << "modal: the equilibrium is unstable (" << modal::describe_stability(a.result()) << ")\n";
        return static_cast<int>(modal::ExitStatus::unstable);
      }
    } else if (*equilibria) {
      const modal::Model model = load_checked(equilibria_scene, modal::Command::equilibria, equilibria_out);
      modal::ProgressBar bar("equilibria", !quiet);
      eo.progress = [&bar](int done, int total) { bar.update(done, total); };
      const modal::EquilibriumSurvey survey = modal::equilibria(model, eo);
      bar.finish();
      modal::write_equilibria(std::cout, survey, equilibria_out);
      for (const std::string& note : survey.unanalyzed) std::cerr << "modal: " << note << '\n';
    } else if (*check) {
      modal::write_summary(std::cout, load(check_scene), check_all ? 0 : 100);
    } else if (*sweep) {
      std::vector<modal::SweepAxis> axes;
      for (const std::string& v : varies) axes.push_back(modal::parse_vary(v));
      const modal::Model model = load_checked(sweep_scene, modal::Command::sweep, sweep_out, sweep_options.extrapolate);
      modal::ProgressBar bar("sweep", !quiet);
      sweep_options.sweep.progress = [&bar](int done, int total) { bar.update(done, total); };
      const modal::SweepStudy study = modal::sweep(model, axes, sweep_options);
      bar.finish();
      modal::write_sweep(std::cout, study, sweep_out);
    } else if (*simulate) {
      const modal::Model model = load_checked(simulate_scene, modal::Command::simulate, simulate_out);
      if (simulate_at_option->count()) sim.at = modal::parse_coordinates(model.system, "--at", simulate_at);
      if (simulate_velocity_option->count())
        sim.velocity = modal::parse_coordinates(model.system, "--velocity", simulate_velocity);
      if (simulate_interval_option->count()) sim.interval = simulate_interval;
      modal::ProgressBar bar("simulate", !quiet);
      sim.progress = [&bar](int done, int total) { bar.update(done, total); };
      const modal::Simulation s = modal::simulate(model, sim);
      bar.finish();
      for (const std::string& note : s.notes) std::cerr << "modal: " << note << '\n';
      modal::write_simulation(std::cout, s, simulate_out);
      modal::print_simulation_summary(std::cerr, s.trajectory, s.options);
    } else if (*convert) {
      if (!convert_output.empty()) modal::check_output_paths({convert_output}, {convert_file});
      std::string toml = modal::convert_scene(convert_file, *modal::parse_scene_format(convert_format));
      if (convert_output.empty()) {
        std::cout << toml;
      } else {
        modal::OutputFiles files;
        files.add(convert_output, std::move(toml));
        files.commit();
      }
    } else if (*amplitude) {
      const modal::Model model = load_checked(amplitude_scene, modal::Command::amplitude, amplitude_out);
      if (amplitude_at_option->count()) amp.at = modal::parse_coordinates(model.system, "--at", amplitude_at);
      modal::ProgressBar bar("amplitude", !quiet);
      amp.options.progress = [&bar](int done, int total) { bar.update(done, total); };
      const modal::AmplitudeStudy study = modal::amplitude(model, amp);
      bar.finish();
      modal::write_amplitude(std::cout, study, amplitude_out);
    }
    return 0;
  } catch (const std::exception& e) {
    std::cerr << modal::error_message(e) << '\n';
    return static_cast<int>(modal::exit_status(e));
  } catch (...) {
    std::cerr << "modal: failure: unknown error\n";
    return static_cast<int>(modal::ExitStatus::numerical);
  }
} catch (const std::bad_alloc& e) {
  try {
    std::cerr << modal::error_message(e) << '\n';
  } catch (...) {  // no memory even for the message
    static const char text[] = "modal: out of memory\n";
    static_cast<void>(write(STDERR_FILENO, text, sizeof text - 1));
  }
  return static_cast<int>(modal::ExitStatus::numerical);
}
