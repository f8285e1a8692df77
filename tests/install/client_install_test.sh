#!/bin/bash
# The client library as another program sees it: install into a temporary prefix, build
# examples/subscribe_print out of tree with find_package(Mimic) and again with pkg-config, and
# run both against a live `mimic run`: each must print posed joints of the walking avatar.
# usage: client_install_test.sh BUILD_DIR SOURCE_DIR MIMIC_BINARY [CXX [SANITIZE]]
# (the example is built with the compiler of the build, and its sanitizers when it has them)
set -euo pipefail
build=$1 src=$2 mimic=$3 cxx=${4:-c++} sanitize=${5:-0}
work=$(mktemp -d)
run_pid=
cleanup() { [ -n "$run_pid" ] && kill "$run_pid" 2>/dev/null; wait 2>/dev/null; rm -rf "$work"; }
trap cleanup EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }

prefix=$work/prefix
cmake --install "$build" --component client --prefix "$prefix" > "$work/install.log"
header=$prefix/include/mimic/client.h
[ -f "$header" ] || fail "no $header"
lib=$(find "$prefix" -name 'libmimic_client.so*' -type f | head -1)
[ -n "$lib" ] || fail "no libmimic_client.so"
config=$(find "$prefix" -name MimicConfig.cmake | head -1)
[ -n "$config" ] || fail "no MimicConfig.cmake"
pc=$(find "$prefix" -name mimic.pc | head -1)
[ -n "$pc" ] || fail "no mimic.pc"
# The public header stands alone: standard C++ only.
if grep -E '#include *[<"](glm|tl|boost|nlohmann|mimic/(net|avatar|core))' "$header"; then fail "public header pulls in internals"; fi
# The library exports the API and nothing of the modules linked into it.
exported=$(nm -D --defined-only "$lib" | c++filt)
echo "$exported" | grep -q 'mimic::client::Subscriber::connect' || fail "Subscriber::connect not exported"
# The C ABI: unmangled symbols, and a header that a C compiler takes alone.
nm -D --defined-only "$lib" | grep -qw 'mimic_subscriber_connect' || fail "mimic_subscriber_connect not exported as C"
[ -f "$prefix/include/mimic/mimic_c.h" ] || fail "no mimic_c.h"
# The C compiler of the build's C++ compiler (a sanitized library needs the same runtime).
case "$cxx" in
  *clang++*) cc=${cxx/clang++/clang} ;;
  *g++*) cc=${cxx/g++/gcc} ;;
  *) cc=cc ;;
esac
printf '#include <mimic/mimic_c.h>\nint main(void) { return mimic_version() == 0; }\n' > "$work/only_c.c"
"$cc" -std=c99 -Wall -Werror -pedantic -fsyntax-only -I"$prefix/include" "$work/only_c.c" || fail "mimic_c.h is not plain C99"
if echo "$exported" | grep -E 'mimic::(net|avatar|core)::' | head -3 | grep .; then fail "internal symbols exported"; fi

# A library built with the sanitizers (MIMIC_SANITIZE) needs their runtime in the program too.
san=
san_c_link=
if [ "$sanitize" = 1 ]; then
  san="-fsanitize=address,undefined"
  # A C program's link leaves out UBSan's C++ part (and the C++ library it needs), which the
  # library, C++ inside, calls into.
  san_c_link="-fsanitize-link-c++-runtime -Wl,--push-state,--no-as-needed -lstdc++ -Wl,--pop-state"
fi

# find_package(Mimic), out of tree.
cmake -S "$src/examples/subscribe_print" -B "$work/example" -DCMAKE_PREFIX_PATH="$prefix" -DCMAKE_BUILD_TYPE=Release \
  -DCMAKE_CXX_COMPILER="$cxx" -DCMAKE_CXX_FLAGS="$san" > "$work/configure.log" || { cat "$work/configure.log"; fail "configure against the installed package"; }
cmake --build "$work/example" > "$work/build.log" || { cat "$work/build.log"; fail "build the example"; }
# pkg-config, with a plain compiler call.
flags=$(PKG_CONFIG_PATH=$(dirname "$pc") pkg-config --cflags --libs mimic)
"$cxx" -std=c++17 $san "$src/examples/subscribe_print/main.cpp" $flags -Wl,-rpath,"$(dirname "$lib")" -o "$work/subscribe_print_pc" \
  || fail "build with pkg-config flags: $flags"

# The C example (find_package(Mimic) -> Mimic::c), out of tree, C only.
cmake -S "$src/examples/mesh_obj" -B "$work/mesh_obj" -DCMAKE_PREFIX_PATH="$prefix" -DCMAKE_BUILD_TYPE=Release \
  -DCMAKE_C_COMPILER="$cc" -DCMAKE_C_FLAGS="$san" -DCMAKE_EXE_LINKER_FLAGS="$san_c_link" > "$work/configure_c.log" || { cat "$work/configure_c.log"; fail "configure the C example"; }
cmake --build "$work/mesh_obj" > "$work/build_c.log" || { cat "$work/build_c.log"; fail "build the C example"; }

# A live scene (deforming its skin at LOD 1 for mesh subscribers).
"$mimic" run --listen 127.0.0.1:0 --quiet --duration 60 --mesh-lod 1 > "$work/run.out" 2> "$work/run.err" &
run_pid=$!
for _ in $(seq 100); do grep -q '^serving on ' "$work/run.out" 2>/dev/null && break; sleep 0.1; done
endpoint=$(sed -n 's/^serving on //p' "$work/run.out" | head -1)
[ -n "$endpoint" ] || { cat "$work/run.err"; fail "mimic run did not start"; }

check_output() {  # FILE: 5 frames of the 23 joints of the default skeleton, the head above the feet
  local out=$1
  grep -q "^# avatar .* 23 joints, 52 DOFs" "$out" || { cat "$out"; fail "no avatar announced"; }
  [ "$(grep -c '^avatar1 [0-9]* head ' "$out")" = 5 ] || { cat "$out"; fail "expected 5 frames of the head"; }
  [ "$(grep -c '^avatar1 ' "$out")" = 115 ] || { cat "$out"; fail "expected 5 x 23 joint lines"; }
  awk '$3 == "head" { h = $5 } $3 == "l_toes" { t = $5 } END { exit !(h - t > 1.2 && h - t < 2.0) }' "$out" \
    || { cat "$out"; fail "head not about 1.5 m above the toes"; }
}
"$work/example/subscribe_print" "$endpoint" --frames 5 > "$work/find_package.out" || fail "find_package example failed"
check_output "$work/find_package.out"
"$work/subscribe_print_pc" "$endpoint" --frames 5 > "$work/pkg_config.out" || fail "pkg-config example failed"
check_output "$work/pkg_config.out"
# The C program writes three mesh frames as OBJ files: every triangle's indices in range, as
# many normals and texture coordinates as vertices (the seams split), normals of unit length, coordinates in [0, 1] and each triangle's corners naming the
# same vertex, normal and coordinate; the body about 1.5-2 m tall.
mkdir -p "$work/objs"
"$work/mesh_obj/mesh_obj" "$endpoint" --lod 1 --frames 3 --out "$work/objs" > "$work/mesh_obj.out" \
  || fail "C mesh example failed: $(cat "$work/mesh_obj.out")"
[ "$(ls "$work/objs"/*.obj | wc -l)" = 3 ] || fail "expected 3 OBJ files"
for obj in "$work/objs"/*.obj; do
  awk '/^v / { v++; if (min == "" || $3 < min) min = $3; if (max == "" || $3 > max) max = $3 }
       /^vn / { n++; l = sqrt($2*$2 + $3*$3 + $4*$4); if (l < 0.99 || l > 1.01) bad++ }
       /^vt / { t++; if ($2 < 0 || $2 > 1 || $3 < 0 || $3 > 1) bad++ }
       /^f / { f++; for (i = 2; i <= 4; i++) { split($i, k, "/"); if (k[1] < 1 || k[1] > v || k[2] != k[1] || k[3] != k[1]) bad++ } }
       END { if (v < 500 || n != v || t != v || f < 500 || bad > 0 || max - min < 1.4 || max - min > 2.2) {
               print "v " v " vn " n " vt " t " f " f " bad " bad " height " max - min; exit 1 } }' "$obj" \
    || fail "$obj is not a whole body"
done
# A LOD the scene does not deform: refused with the LODs served.
if "$work/mesh_obj/mesh_obj" "$endpoint" --lod 3 --frames 1 --out "$work/objs" 2> "$work/refused.err"; then
  fail "LOD 3 should be refused"
fi
grep -q "served: 1" "$work/refused.err" || { cat "$work/refused.err"; fail "the refusal does not say which LOD is served"; }

echo "client library: installed, found by find_package and pkg-config, subscribed and printed joints; the C ABI wrote mesh frames as OBJ"
head -3 "$work/find_package.out"
