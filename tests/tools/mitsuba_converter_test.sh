#!/usr/bin/env bash
# ctest tools.mitsuba_converter: bench/mitsuba/scene_to_mitsuba.py's output renders in Mitsuba 3 to
# the photonflow image's mean within 1 % on an untextured and a textured scene
# (tests/tools/mitsuba_converter_test.py says how). Mitsuba is benchmark-only, never a dependency:
# where its venv (PF_SOURCE_DIR/.venv-mitsuba, bench/mitsuba/README.md), the mitsuba module or
# libLLVM 19 is missing, as in CI, the test prints why and exits 77 (ctest: skipped).
# Environment: PF_BIN, PF_SOURCE_DIR (set by ctest); MITSUBA_PY (default
# PF_SOURCE_DIR/.venv-mitsuba/bin/python); DRJIT_LIBLLVM_PATH (default
# PF_SOURCE_DIR/.llvm19/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1); DRJIT_CACHE_DIR (default
# PF_BIN/../drjit-cache, so the kernels compile once).
set -euo pipefail
: "${PF_BIN:?}" "${PF_SOURCE_DIR:?}"
PY=${MITSUBA_PY:-$PF_SOURCE_DIR/.venv-mitsuba/bin/python}
export DRJIT_LIBLLVM_PATH=${DRJIT_LIBLLVM_PATH:-$PF_SOURCE_DIR/.llvm19/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1}
export DRJIT_CACHE_DIR=${DRJIT_CACHE_DIR:-$PF_BIN/../drjit-cache}
skip() { echo "SKIPPED: $*"; exit 77; }
[ -x "$PY" ] || skip "no Mitsuba venv at $PY (bench/mitsuba/README.md, Setup)"
"$PY" -c "import mitsuba, drjit, h5py, numpy" 2>/dev/null || skip "$PY cannot import mitsuba, drjit, h5py and numpy"
[ -f "$DRJIT_LIBLLVM_PATH" ] || skip "libLLVM 19 not at $DRJIT_LIBLLVM_PATH (llvm_ad_rgb needs it; bench/mitsuba/README.md)"
for t in scene-bake pathtrace; do [ -x "$PF_BIN/$t" ] || { echo "FAIL: $PF_BIN/$t missing"; exit 1; }; done
WORK=$(mktemp -d)
trap 'rm -rf "$WORK"' EXIT
"$PY" "$PF_SOURCE_DIR/tests/tools/mitsuba_converter_test.py" "$PF_BIN" "$PF_SOURCE_DIR" "$WORK"
