#!/usr/bin/env bash
# Installs everything modal needs on Debian 12 (bookworm) from Debian's packages.
# Runs apt-get as root, or through sudo when started by another user.
set -euo pipefail

packages=(
  build-essential cmake pkg-config
  ccache               # scripts/test.sh compiles through it: a repeated test run rebuilds only what changed
  libeigen3-dev        # dense linear algebra, Eigen 3.4
  libspectra-dev       # sparse/iterative eigen-solvers, Spectra 1.0
  libsuitesparse-dev   # CHOLMOD sparse Cholesky (shift-invert of the sparse eigen-solver)
  liblapack-dev        # LAPACK interface (dsygvd, the dense symmetric-definite eigen-solver)
  libmumps-seq-dev     # MUMPS sparse LDLᵀ with pivoting: inertia and indefinite shifts of the sparse eigen-solver
  libopenblas0-pthread # optimized BLAS/LAPACK for the dense kernels of CHOLMOD and MUMPS (the reference BLAS
                       # spends half of a 10⁶-coordinate analysis in dgemm); the pthread build, not the OpenMP one,
                       # which starts no threads on load but made a 10⁵-coordinate net's equilibrium 1.8× slower
  libpetsc-real-dev libslepc-real-dev openmpi-bin libopenmpi-dev  # the distributed backend, modal-mpi
                       # (analyze --backend petsc; MODAL_WITH_PETSC, ON when these are found)
  libjemalloc-dev      # optional allocator of the program (cmake -DMODAL_JEMALLOC=ON)
  libnlopt-cxx-dev     # NLopt with its C++ API (equilibrium searches)
  libgsl-dev           # GSL: ODE integration (energy conservation, simulation)
  libcli11-dev         # command line
  libtomlplusplus-dev  # scene files (TOML)
  libmujoco-dev        # MJCF and URDF scenes: libmujoco compiles them (mj_loadXML), modal imports the compiled model
  libfmt-dev           # text tables
  nlohmann-json3-dev   # JSON output
  libgtest-dev libgmock-dev  # tests
  clang libclang-rt-14-dev   # tests: the libFuzzer target on the scene reader (fuzz/)
  libbenchmark-dev     # benchmarks
  libginac-dev         # benchmark only: bench_expression measures GiNaC against our expressions
  python3-sympy        # benchmark only: the SymPy mechanics peer of bench/map_linearize.sh
  python3-scipy python3-matplotlib  # Python tests (scipy's eigh/eigsh check the bindings; examples/python plots a
                       # sweep) and benchmarks (scipy eigsh peer and the plot of bench/sparse_scaling.sh)
  python3-dev pybind11-dev  # the Python module `modal` (python/), built for Debian's /usr/bin/python3
  python3-numpy        # the Python module's arrays (needed to build it: MODAL_BUILD_PYTHON is ON when found)
  python3-pytest       # the Python tests (python/tests, run by ctest)
  chromium             # tests: tests/report_browser.py opens the HTML reports in headless Chromium;
                       # scripts/report_screenshots.sh takes results/report_*.png with it
  help2man             # the man page modal.1, generated from --help at build time (optional: none without it)
  doxygen              # the API reference: cmake --build build --target docs (Doxygen over the public headers)
  dpkg-dev file        # cpack -G DEB: dpkg-shlibdeps finds the package's Depends, file spots the ELF files
)

# Node.js and npm: the build installs uPlot (pinned in lib/report/web/package-lock.json) with `npm ci` and
# inlines it into the HTML reports (analyze --report). Debian's nodejs and npm, unless an npm is already
# there: a Node.js from another repository (NodeSource's nodejs package carries its own npm and conflicts
# with Debian's npm package) is used as it is.
if ! command -v npm > /dev/null; then packages+=(nodejs npm); fi

if [ "$(id -u)" -eq 0 ]; then sudo=""; else sudo="sudo"; fi
# Only touch apt when something is missing, so repeated runs are fast and offline-safe.
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  echo "setup: installing ${missing[*]}"
  $sudo apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq --no-install-recommends "${missing[@]}"
else
  echo "setup: all dependencies are installed"
fi

# Debian's alternatives choose which BLAS/LAPACK libblas.so.3, liblapack.so.3 and libopenblas.so.0
# are; another BLAS installed beside OpenBLAS's pthread build (its OpenMP
# build, say) may have been chosen. Select the pthread build (see above).
arch=$(dpkg-architecture -qDEB_HOST_MULTIARCH 2>/dev/null || gcc -dumpmachine)
for lib in libblas.so.3 liblapack.so.3 libopenblas.so.0; do
  target=/usr/lib/$arch/openblas-pthread/$lib
  current=$(readlink -f "/usr/lib/$arch/$lib" || true)
  if [ -e "$target" ] && [ "$current" != "$(readlink -f "$target")" ]; then
    echo "setup: selecting $target for $lib"
    $sudo update-alternatives --set "$lib-$arch" "$target"
  fi
done
