#!/usr/bin/env bash
# bench/gpu.sh — the GPU columns of the benchmarks (Tables 7.3–7.5, 8.4) on a machine that has an
# OpenCL GPU driver but none of photonflow's Debian packages and no network (the lent GPU machines
# of docs/BENCHMARKS.md, "OpenCL backend").
#
#   bench/gpu.sh pack [BUILD]      here: copies the benchmark and OpenCL test binaries of BUILD
#                                  (default build) and the shared libraries they need (less the C
#                                  library itself) into .gpu/ (ignored by git; carry it)
#   bench/gpu.sh run WHAT [ARGS]   there, from the repository root: runs WHAT with .gpu/'s
#                                  binaries on the GPU, writing WHAT.md (and WHAT.log) under $OUT
#                                  (default out/gpu):
#       devices   the OpenCL platforms and devices the binaries see
#       check     the OpenCL correctness tests (CPU backend vs device; every gather method
#                 gathers the same photons as the CPU; the shared headers rng.h, ppm.h and
#                 intersect_shared.h built by the driver give the host's results; the GA's
#                 clusters and device-time fitness)
#       gather    Tables 7.3–7.5 (bench_gather --runs 5)
#       targets   the GPU targets of "Accelerated gathers" alone (a few minutes): naive against
#                 hash-grid at 320×280 and 1920×1080 (bench_gather --runs 5), once with the GPU's
#                 default gather and once with the CPU devices' pending list (PF_GATHER_LIST=32)
#       ga        Table 8.4, the device-time fitness (bench_ga, 3 runs × 300 generations × 50;
#                 the CPU fitnesses of Tables 8.1–8.3 are skipped, they do not use the device)
#       opencl    the per-block table of "OpenCL backend" (bench_opencl --runs 5)
#     ARGS are passed on to the benchmark (e.g. --cl-platform 1 --cl-device 0).
#
# The NVIDIA driver registers no ICD file on those machines (their /etc/OpenCL/vendors names only a
# PoCL that finds no device there, as on the H100 machine); `run` writes one naming
# libnvidia-opencl.so.1 (when found) into a temporary vendors folder and points OCL_ICD_VENDORS at
# it, so the NVIDIA platform is the only one. Without that library, or with OCL_ICD_VENDORS already
# set, the ICD loader's usual search applies.
set -euo pipefail

BINS=(bench_gather bench_ga bench_opencl render)
TESTS=(cl_backend_test gather_method_test cl_shared_headers_test intersect_shared_cl_test
       ga_clusters_test)
# Catch2 test specs per test program where not all of it can run there: ga_clusters_test's other
# cases run the tools, which are not carried.
declare -A TEST_SPEC=([ga_clusters_test]="[opencl]")

pack() {
  local build=${1:-build}
  [ -x "$build/bin/bench_gather" ] || {
    echo "gpu.sh: $build/bin/bench_gather not found: build first (make build, or cmake --build $build)" >&2
    exit 2
  }
  rm -rf .gpu
  mkdir -p .gpu/lib
  local f
  for f in "${BINS[@]}"; do cp "$build/bin/$f" .gpu/; done
  for f in "${TESTS[@]}"; do cp "$build/tests/$f" .gpu/; done
  # Every library the binaries load, except the C runtime and the dynamic loader, which the
  # target machine has (and must match its kernel); PoCL is not needed there.
  { for f in "${BINS[@]}" "${TESTS[@]}"; do ldd ".gpu/$f"; done; } | awk '$3 ~ /^\// {print $3}' | sort -u |
    grep -Ev '/(libc|libm|libpthread|libdl|librt|libresolv|ld-linux[^/]*)\.so' | while read -r lib; do
      cp -L "$lib" .gpu/lib/
    done
  echo "gpu.sh: .gpu holds $((${#BINS[@]} + ${#TESTS[@]})) binaries and $(ls .gpu/lib | wc -l) libraries," \
       "$(du -sh .gpu | cut -f1); carry .gpu"
}

find_nvidia_icd() {
  local d
  for d in /usr/lib/x86_64-linux-gnu /usr/lib64 /usr/local/nvidia/lib64 /usr/lib /usr/local/cuda/lib64; do
    [ -e "$d/libnvidia-opencl.so.1" ] && { echo "$d/libnvidia-opencl.so.1"; return; }
  done
  ldconfig -p 2>/dev/null | awk '/libnvidia-opencl\.so\.1/ {print $NF; exit}'
}

run() {
  local what=${1:-}
  shift || true
  [ -d .gpu ] || { echo "gpu.sh: no .gpu folder: run 'bench/gpu.sh pack' and carry .gpu" >&2; exit 2; }
  local out=${OUT:-out/gpu}
  mkdir -p "$out"
  export LD_LIBRARY_PATH="$PWD/.gpu/lib${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}"
  # The header tests build kernels from this tree's libcommon/ (tests/support.h, source_dir).
  export PF_SOURCE_DIR=$PWD
  if [ -z "${OCL_ICD_VENDORS:-}" ]; then
    local icd
    icd=$(find_nvidia_icd || true)
    if [ -n "$icd" ]; then
      local vendors
      vendors=$(mktemp -d)
      echo "$icd" > "$vendors/nvidia.icd"
      export OCL_ICD_VENDORS=$vendors
    fi
  fi
  local g=.gpu
  # The tests skip their device cases when no OpenCL device is found, and the benchmarks would
  # time PoCL: refuse to run without a GPU in the list.
  if [ "$what" != devices ] && ! "$g/render" --list-devices 2>/dev/null | grep -q '\[GPU\]'; then
    echo "gpu.sh: no OpenCL GPU device found (bench/gpu.sh run devices lists what there is)" >&2
    exit 3
  fi
  case "$what" in
    devices) "$g/render" --list-devices "$@" 2>&1 | tee "$out/devices.md" ;;
    check)
      # Every program runs, also after one fails; the exit status says whether any failed.
      { nvidia-smi -L 2>/dev/null || true
        failed=0
        for t in "${TESTS[@]}"; do
          echo "== $t ${TEST_SPEC[$t]:-}"
          "$g/$t" ${TEST_SPEC[$t]:+"${TEST_SPEC[$t]}"} "$@" || failed=1
        done
        exit $failed; } 2>&1 | tee "$out/check.log" ;;
    gather) "$g/bench_gather" --runs 5 "$@" > "$out/gather.md" 2> "$out/gather.log"; cat "$out/gather.md" ;;
    targets)
      targets() {
        "$g/bench_gather" --runs 5 --sizes 320x280,1920x1080 --cluster-sizes "" \
          --methods naive,hash-grid "$@"
      }
      { echo "## default kernels"
        targets "$@"
        echo
        echo "## PF_CL_BUILD_OPTIONS=-DPF_GATHER_LIST=32"
        PF_CL_BUILD_OPTIONS=-DPF_GATHER_LIST=32 targets "$@"
      } > "$out/targets.md" 2> "$out/targets.log"
      cat "$out/targets.md" ;;
    ga)
      "$g/bench_ga" --runs 0 --device-fitness-runs 3 "$@" > "$out/ga.md" 2> "$out/ga.log"
      cat "$out/ga.md" ;;
    opencl) "$g/bench_opencl" --runs 5 "$@" > "$out/opencl.md" 2> "$out/opencl.log"; cat "$out/opencl.md" ;;
    *) echo "gpu.sh: run what? devices, check, gather, targets, ga or opencl" >&2; exit 2 ;;
  esac
}

case "${1:-}" in
  pack) shift; pack "$@" ;;
  run) shift; run "$@" ;;
  *) echo "usage: bench/gpu.sh pack [BUILD] | run devices|check|gather|targets|ga|opencl [ARGS]" >&2; exit 2 ;;
esac
