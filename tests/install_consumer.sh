#!/usr/bin/env bash
# ctest install_consumer: installs the build to a temporary prefix (under the
# build tree), checks what is installed, then builds examples/embed against
# it, once through the CMake package (modal::modal, and modal::modal_static)
# and once through pkg-config, and checks their output against the closed
# form of the double pendulum (R1, m = l = g = 1): ω² = 2 ∓ √2, to 1e-12
# relative.
# Usage: install_consumer.sh BUILD_DIR SOURCE_DIR CXX_COMPILER LAUNCHER SANITIZE(ON|OFF) MAN_PAGE(ON|OFF)
set -euo pipefail
build=$1 source=$2 cxx=$3 launcher=$4 sanitize=$5 man=$6

work=$build/install-consumer
prefix=$work/prefix
rm -rf "$work"
mkdir -p "$work"
cmake --install "$build" --prefix "$prefix" > "$work/install.log"

fail() { echo "install_consumer: $*" >&2; exit 1; }
libdir=lib
[ -d "$prefix/$libdir/cmake/modal" ] || libdir=$(cd "$prefix" && ls -d lib/*/cmake/modal | sed 's|/cmake/modal$||')
for f in bin/modal "$libdir/libmodal.so.0.2.0" "$libdir/libmodal.so.0" "$libdir/libmodal.so" "$libdir/libmodal.a" \
         include/modal/modes.hpp include/modal/scene.hpp \
         "$libdir/cmake/modal/modalConfig.cmake" "$libdir/cmake/modal/modalConfigVersion.cmake" \
         "$libdir/cmake/modal/modalTargets.cmake" "$libdir/cmake/modal/modalStaticTargets.cmake" \
         "$libdir/cmake/modal/FindCHOLMOD.cmake" "$libdir/cmake/modal/FindMUMPS.cmake" \
         "$libdir/pkgconfig/modal.pc" share/modal/models/double_pendulum.toml share/modal/models/data/tower_nodes.csv; do
  [ -e "$prefix/$f" ] || fail "not installed: $f"
done
if [ "$man" = ON ]; then
  [ -s "$prefix/share/man/man1/modal.1" ] || fail "not installed: share/man/man1/modal.1"
  grep -q '^\.SS "modal analyze"' "$prefix/share/man/man1/modal.1" || fail "modal.1 lacks the analyze subcommand"
fi
soname=$(objdump -p "$prefix/$libdir/libmodal.so.0.2.0" | awk '$1 == "SONAME" {print $2}')
[ "$soname" = libmodal.so.0 ] || fail "SONAME is '$soname', not libmodal.so.0"

# A sanitizer build's library needs the consumer built and linked likewise.
flags=""
[ "$sanitize" = ON ] && flags="-fsanitize=address,undefined -fno-sanitize-recover=all"
export ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=1}

version=$("$prefix/bin/modal" --version)
[ "$version" = "modal 0.2.0" ] || fail "installed modal --version is not 'modal 0.2.0'"

model=$prefix/share/modal/models/double_pendulum.toml
# ω² of the two modes against the closed form c ∓ √d (R1: 2 ∓ √2 with unit
# masses; m2 = 2: the roots of x² − 6x + 3, 3 ∓ √6), awk in double precision.
check() {
  local name=$1 out=$2 c=${3:-2} d=${4:-2}
  echo "$name:"; echo "$out"
  echo "$out" | awk -v name="$name" -v c="$c" -v d="$d" '
    $1 == "mode" { w[$2] = $4; n++ }
    END {
      if (n != 2) { print name ": expected 2 modes, got " n; exit 1 }
      e[1] = c - sqrt(d); e[2] = c + sqrt(d)
      for (k = 1; k <= 2; k++) {
        r = (w[k] - e[k]) / e[k]; if (r < 0) r = -r
        printf "%s: mode %d omega2 %.17g, closed form %.17g, relative error %.1e\n", name, k, w[k], e[k], r
        if (!(r <= 1e-12)) { print name ": mode " k " off by more than 1e-12"; exit 1 }
      }
    }' || fail "$name: wrong ω²"
}

# 1. CMake: find_package(modal 0.2 REQUIRED COMPONENTS static), modal::modal and modal::modal_static.
cmake -S "$source/examples/embed" -B "$work/embed" -DCMAKE_PREFIX_PATH="$prefix" -DCMAKE_BUILD_TYPE=Release \
      -DCMAKE_CXX_COMPILER="$cxx" ${launcher:+-DCMAKE_CXX_COMPILER_LAUNCHER="$launcher"} \
      -DCMAKE_CXX_FLAGS="$flags" -DCMAKE_EXE_LINKER_FLAGS="$flags" -DEMBED_STATIC=ON > "$work/embed-configure.log" \
  || { cat "$work/embed-configure.log"; fail "examples/embed does not configure"; }
cmake --build "$work/embed" > "$work/embed-build.log" 2>&1 \
  || { cat "$work/embed-build.log"; fail "examples/embed does not build"; }
# Captured first: with pipefail, "objdump | grep -q" fails whenever grep stops
# reading before objdump has written everything (objdump dies of SIGPIPE).
needed=$(objdump -p "$work/embed/embed" | awk '$1 == "NEEDED" {print $2}')
grep -qx 'libmodal\.so\.0' <<< "$needed" || fail "embed does not link libmodal.so.0 (NEEDED: $(echo $needed))"
check "embed (modal::modal)" "$("$work/embed/embed" "$model")"
check "embed_static (modal::modal_static)" "$("$work/embed/embed_static" "$model")"
# Overrides and the JSON writer through the pipeline API; errors carry the CLI's status and message.
check "embed m2=2" "$("$work/embed/embed" "$model" m2=2 --json "$work/dp.json")" 3 6
grep -q '"stability": "stable"' "$work/dp.json" || fail "embed --json: no stability in $work/dp.json"
status=0; err=$("$work/embed/embed" "$work/missing.toml" 2>&1) || status=$?
[ "$status" = 2 ] || fail "embed of a missing scene: exit status $status, expected 2 (bad input)"
grep -q "missing.toml" <<< "$err" || fail "embed of a missing scene: the message does not name the file: $err"
status=0; err=$("$work/embed/embed" "$model" m9=1 2>&1) || status=$?
[ "$status" = 2 ] || fail "embed with an unknown parameter: exit status $status, expected 2"
echo "embed: exit status 2 and '$err'"

# 2. pkg-config: one compile-and-link line.
export PKG_CONFIG_PATH=$prefix/$libdir/pkgconfig
pc_flags=$(pkg-config --cflags --libs modal) || fail "pkg-config --cflags --libs modal failed"
echo "pkg-config --cflags --libs modal: $pc_flags"
# shellcheck disable=SC2086  # the flags are words
$launcher "$cxx" -std=c++20 -O2 $flags "$source/examples/embed/main.cpp" -o "$work/embed_pc" $pc_flags \
  -Wl,-rpath,"$prefix/$libdir" || fail "the pkg-config build of examples/embed/main.cpp failed"
check "embed (pkg-config)" "$("$work/embed_pc" "$model")"
echo "install_consumer: all checks passed"
