"""modal: linearization and modal analysis of Lagrangian mechanical systems.

The Python face of modal's C++ library (modal/pipeline.hpp): exactly what the
`modal` command computes, as numpy values.

    import modal
    a = modal.analyze("models/double_pendulum.toml", set={"m2": 2})
    a.omega2, a.errors          # ω² (rad²/s²) of each mode and its error estimate
    a.M, a.K                    # the linear model (numpy; scipy.sparse on the sparse path)
    a.shapes                    # n × k, M-normalized
    print(a.text())             # the table `modal analyze` prints

    s = modal.sweep("models/ziegler.toml", vary="P=0:4:41")
    s.values, s.stability, s.critical[0]["value"]   # flutter at 7/2 − √2

Scenes are given as a path, TOML text, a dict, or a Model from modal.load();
`set` overrides parameters ({"m": 2.0, "l": "2*a"}: numbers or expressions).
Every function raises modal.Error (SceneError, InputError, NumericalError, …)
with the message the command prints and its exit status (e.exit_status).
Units are SI: ω² in rad²/s², ω in rad/s, coordinates in rad or m.
"""

import os as _os

from . import _modal
from ._modal import (Analysis, Amplitude, EnergyDistribution, Equilibria, Error, InputError, Model, NotAnEquilibrium,
                     NumericalError,
                     ReportError, SceneError, SingularMassMatrix, Simulation, Sweep, SweepInputError, __version__)
from ._toml import dumps as _toml_dumps

__all__ = [
    "load", "analyze", "equilibria", "sweep", "simulate", "amplitude",
    "Model", "Analysis", "EnergyDistribution", "Equilibria", "Sweep", "Simulation", "Amplitude",
    "Error", "SceneError", "InputError", "SweepInputError", "ReportError", "NumericalError",
    "SingularMassMatrix", "NotAnEquilibrium", "__version__",
]


def _overrides(set):
    """{"m": 2.0, "l": "2*a"} or ["m=2", …] → ["m=2.0", "l=2*a"]."""
    if set is None:
        return []
    if isinstance(set, dict):
        out = []
        for name, value in set.items():
            if hasattr(value, "item") and not isinstance(value, str):
                value = value.item()  # numpy scalars
            if isinstance(value, bool) or not isinstance(value, (int, float, str)):
                raise TypeError(f"set[{name!r}]: a parameter's value is a number or an expression string, "
                                f"got {type(value).__name__}")
            out.append(f"{name}={value!r}" if isinstance(value, float) else f"{name}={value}")
        return out
    if isinstance(set, str):
        return [set]
    return [str(item) for item in set]


def _looks_like_text(source):
    # TOML text has a line break or an '=' (a key = value); a path normally neither.
    return "\n" in source or ("=" in source and not _os.path.exists(source))


def load(source, set=None, *, name=None):
    """Reads a scene and builds its system.

    source: a path (str or os.PathLike) to a .toml scene file; TOML text (a str
    with a line break or an '='); a dict laid out as a scene file (sub-dicts are
    [tables], lists of dicts [[arrays of tables]], e.g. {"body": [{...}, {...}]});
    or a Model (returned as it is, or rebuilt from its text with further
    overrides).
    set: parameter overrides, {"m": 2.0, "l": "2*a"} (numbers or expressions
    over the other parameters) or ["m=2", "l=2*a"].
    name: the file name used in messages for text and dicts (default
    '<string>', '<dict>'); relative data files (a network's CSV) are resolved
    against its directory.

    Raises SceneError ('file:line:column: key: reason').
    """
    overrides = _overrides(set)
    if isinstance(source, Model):
        if not overrides:
            return source
        return _modal._load_text(source.text, source.file, source.overrides + overrides)
    if isinstance(source, dict):
        return _modal._load_text(_toml_dumps(source), name or "<dict>", overrides)
    if isinstance(source, _os.PathLike):
        return _modal._load_file(_os.fspath(source), overrides)
    if isinstance(source, bytes):
        source = source.decode()
    if isinstance(source, str):
        if _looks_like_text(source):
            return _modal._load_text(source, name or "<string>", overrides)
        return _modal._load_file(source, overrides)
    raise TypeError(f"a scene is a path, TOML text, a dict or a modal.Model, got {type(source).__name__}")


def _model(scene, set):
    if isinstance(scene, Model) and set is None:
        return scene
    return load(scene, set)


def _vector(values):
    if values is None:
        return None
    if isinstance(values, str):
        return [float(v) for v in values.split(",")]
    return values


def analyze(scene, set=None, *, modes=None, at=None, solver="auto", shift=None, tol=1e-10, dense_solver="auto",
            derivatives="exact", step=None, eq_tol=1e-12, large_equilibrium="newton", energy=False,
            drawing=False):
    """Finds the equilibrium nearest the scene's initial configuration (or
    polishes `at`), linearizes there and solves for the modes: `modal analyze`.

    scene, set: as for load().
    modes: the number of lowest modes (default: all on the dense path, 10 on the
    sparse one). at: an equilibrium to analyze (n values). solver: 'auto'
    (sparse above 1000 coordinates when the scene allows), 'dense', 'sparse'.
    shift: sparse: modes nearest σ (rad²/s²). tol: sparse: Lanczos tolerance.
    dense_solver: 'auto', 'eigen', 'lapack'. derivatives: 'exact', 'central',
    'forward', 'complex-step' (K by differences; dense only), step: their step
    factor. eq_tol: the equilibrium's accepted relative residual.
    large_equilibrium: 'newton' or 'lbfgs' (large scenes).
    energy: also compute each mode's energy distribution and its participation
    in base translation (Analysis.energy, an EnergyDistribution: `--energy`).
    drawing: also compute what an HTML report animates (each mode's motion of
    the scene's points), for Analysis.write(report="FILE.html").

    Returns an Analysis (omega2, errors, bounds, shapes, q, M, K, D, G,
    stability, …). Raises SceneError, InputError, NumericalError.
    """
    model = _model(scene, set)
    options = _modal._analysis_options(-1 if modes is None else modes, _vector(at), solver, shift, tol, dense_solver,
                                       derivatives, 0.0 if step is None else step, eq_tol, large_equilibrium,
                                       bool(energy), bool(drawing))
    return _modal._analyze(model, options)


def equilibria(scene, set=None, *, starts=None, tol=1e-12, max_iterations=100):
    """Enumerates the equilibria from `starts` deterministic starts (default:
    64 up to 30 coordinates, then 64·(30/n)², at least 2; each
    polished by Newton's method to the relative residual `tol`) and analyzes
    each: `modal equilibria`. Returns Equilibria (q, potential, stability,
    morse_index, omega2, … one row per equilibrium, sorted by potential).
    """
    return _modal._equilibria(_model(scene, set), -1 if starts is None else starts, tol, max_iterations)


def sweep(scene, vary, set=None, *, modes=None, extrapolate=False, tol=1e-10, refine=True, max_evaluations=200):
    """Follows the equilibrium along a parameter, classifies every point and
    refines the values where the stability class changes: `modal sweep`.

    vary: 'NAME=FROM:TO:COUNT' or 'NAME=V1,V2,...' (a str, or a list of one);
    a list of two makes a stability map. modes: modes kept per point (default
    all; with extrapolate the number extrapolated, default 3). extrapolate:
    Richardson extrapolation along an integer axis (a number of links).
    tol: relative width to which critical values are refined.

    Returns a Sweep: values, ok, stability, min_omega2, max_growth_rate,
    omega2 (points × modes), critical (list of dicts: value, error, kind, …).
    Raises SweepInputError for a malformed or unknown axis.
    """
    axes = [vary] if isinstance(vary, str) else list(vary)
    return _modal._sweep(_model(scene, set), axes, -1 if modes is None else modes, extrapolate, tol, refine,
                         max_evaluations)


def simulate(scene, duration, set=None, *, at=None, velocity=None, interval=None, tol=1e-12):
    """Integrates the nonlinear equations of motion from `at` (default: the
    scene's initial configuration) with velocities `velocity` (default 0) for
    `duration` seconds, sampling every `interval` (default duration/1000):
    `modal simulate`. Returns a Simulation: time, q, qdot, energy, work,
    energy_error (samples × …).
    """
    return _modal._simulate(_model(scene, set), duration, _vector(at), _vector(velocity), interval, tol)


def amplitude(scene, mode=1, set=None, *, at=None, amplitudes=None, max_amplitude=None, points=10, cycles=4,
              tol=1e-12, levels=(0.01, 0.1)):
    """Releases mode `mode` (1 = the lowest) from rest at growing amplitudes and
    measures the frequency of the nonlinear motion: `modal amplitude`.

    amplitudes: the amplitudes (ascending; rad or m of the shape's largest
    component), or `points` values up to max_amplitude (default 2.5 rad or half
    the length scale). levels: departures |ω/ω_lin − 1| whose amplitudes are
    sought. Returns an Amplitude: amplitudes, omega, shift, thresholds.
    """
    return _modal._amplitude(_model(scene, set), mode, _vector(at), [] if amplitudes is None else list(amplitudes),
                             0.0 if max_amplitude is None else max_amplitude, points, cycles, tol, list(levels))
