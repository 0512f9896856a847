# photonflow — top-level entry points.
#
#   make render   install missing Debian packages, build the tools (Release), render the default scene
#   make test     install missing Debian packages, build everything (Release), run the tests (ctest)
#   make test-sanitize  the test suite under AddressSanitizer + UBSan (build-sanitize/; slow build)
#   make test-tsan      the test suite under ThreadSanitizer, Clang + libomp + Archer (build-tsan/)
#   make bench    build and run the benchmarks (long; results go to docs/BENCHMARKS.md by hand)
#   make ch6      the thesis's ch. 6 experiments: tables and charts into docs/results/
#   make accuracy speed against accuracy: error vs time and passes, charts into docs/results/
#
# Variables: SCENE (a name in data/, default cornell-box, or a path to any scene file scene-bake
# reads, e.g. SCENE=models/ship.glb: intermediates under OUT/ship/), OUT (default out), BUILD (default build),
# JOBS (default: all cores), SAN_BUILD (default build-sanitize), TSAN_BUILD (default build-tsan).
BUILD ?= build
JOBS  ?= $(shell nproc)
SCENE ?= cornell-box
OUT   ?= out
BIN   := $(abspath $(BUILD))/bin
include pipelines/scene.mk

.PHONY: all deps configure build build-tools render test test-sanitize test-tsan bench ch6 accuracy clean help
all: build

help:
	@sed -n '2,13p' Makefile | sed 's/^# \{0,1\}//'

deps:
	@tools/setup/install-deps.sh

configure: deps
	@mkdir -p $(BUILD)
	@cmake -S . -B $(BUILD) -DCMAKE_BUILD_TYPE=Release > $(BUILD)/configure.log 2>&1 \
	  || { cat $(BUILD)/configure.log; exit 1; }

# `make render` builds the library and the tools only (CMake target `tools`); `make test`, `make
# bench` and the experiments build everything (the tests and benchmarks too).
build: configure
	@cmake --build $(BUILD) -j$(JOBS)

build-tools: configure
	@cmake --build $(BUILD) -j$(JOBS) --target tools

render: build-tools
	@$(MAKE) --no-print-directory -f pipelines/render.mk BIN=$(BIN) SCENE=$(SCENE) OUT=$(OUT)

test: build
	@tools/setup/install-deps.sh debian-packages.txt debian-packages-test.txt
	@cd $(BUILD) && ctest --output-on-failure -j$(JOBS)

# Every process the tests start (the tools too) writes its sanitizer reports into
# $(SAN_BUILD)/sanitizer-logs/; any report fails the target, also one from a tool whose exit status
# a test expected to be non-zero. Leak checking is off: PoCL's and LLVM's own allocations are
# never freed.
SAN_BUILD ?= build-sanitize
SAN_LOGS  := $(abspath $(SAN_BUILD))/sanitizer-logs
test-sanitize: deps
	@mkdir -p $(SAN_BUILD)
	@cmake -S . -B $(SAN_BUILD) -DCMAKE_BUILD_TYPE=RelWithDebInfo -DPHOTONFLOW_SANITIZE=ON \
	  -DPHOTONFLOW_BENCH=OFF > $(SAN_BUILD)/configure.log 2>&1 || { cat $(SAN_BUILD)/configure.log; exit 1; }
	@cmake --build $(SAN_BUILD) -j$(JOBS)
	@rm -rf $(SAN_LOGS) && mkdir -p $(SAN_LOGS)
	@cd $(SAN_BUILD) && ASAN_OPTIONS=detect_leaks=0:log_path=$(SAN_LOGS)/asan \
	  UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1:log_path=$(SAN_LOGS)/ubsan \
	  ctest --output-on-failure -j$(JOBS); rc=$$?; \
	if [ -n "$$(ls -A $(SAN_LOGS))" ]; then \
	  echo "test-sanitize: sanitizer reports in $(SAN_LOGS):" >&2; head -n 20 $(SAN_LOGS)/* >&2; exit 1; \
	fi; [ $$rc -eq 0 ] && echo "test-sanitize: tests passed, no sanitizer reports"; exit $$rc

# ThreadSanitizer needs Clang: libomp with the Archer tool (OMP_TOOL_LIBRARIES) tells it how
# OpenMP's barriers and reductions synchronise. Code it cannot see (PoCL's threads, HDF5) is
# ignored. Reports go to $(TSAN_BUILD)/sanitizer-logs/; any report fails the target.
TSAN_BUILD ?= build-tsan
TSAN_LOGS  := $(abspath $(TSAN_BUILD))/sanitizer-logs
ARCHER     := /usr/lib/llvm-15/lib/libarcher.so
test-tsan: deps
	@tools/setup/install-deps.sh debian-packages-tsan.txt
	@mkdir -p $(TSAN_BUILD)
	@CC=clang-15 CXX=clang++-15 cmake -S . -B $(TSAN_BUILD) -DCMAKE_BUILD_TYPE=RelWithDebInfo \
	  -DPHOTONFLOW_SANITIZE_THREAD=ON -DPHOTONFLOW_BENCH=OFF > $(TSAN_BUILD)/configure.log 2>&1 \
	  || { cat $(TSAN_BUILD)/configure.log; exit 1; }
	@cmake --build $(TSAN_BUILD) -j$(JOBS)
	@rm -rf $(TSAN_LOGS) && mkdir -p $(TSAN_LOGS)
	@cd $(TSAN_BUILD) && OMP_TOOL_LIBRARIES=$(ARCHER) \
	  TSAN_OPTIONS=ignore_noninstrumented_modules=1:log_path=$(TSAN_LOGS)/tsan \
	  ctest --output-on-failure -j$(JOBS); rc=$$?; \
	if [ -n "$$(ls -A $(TSAN_LOGS))" ]; then \
	  echo "test-tsan: sanitizer reports in $(TSAN_LOGS):" >&2; head -n 20 $(TSAN_LOGS)/* >&2; exit 1; \
	fi; [ $$rc -eq 0 ] && echo "test-tsan: tests passed, no sanitizer reports"; exit $$rc

bench: build
	@$(MAKE) --no-print-directory -f pipelines/bench.mk BIN=$(BIN) OUT=$(OUT)

ch6: build
	@$(MAKE) --no-print-directory -f pipelines/ch6.mk BUILD=$(BUILD) OUT=$(OUT)

accuracy: build
	@$(MAKE) --no-print-directory -f pipelines/accuracy.mk BUILD=$(BUILD) OUT=$(OUT)

clean:
	rm -rf $(BUILD)

# On a Slurm cluster (pipelines/slurm/; `make slurm-help` prints this block's help).
#   make slurm-render    bake SCENE, submit a job array of TASKS tasks (task k renders passes
#                        k*PASSES_PER_TASK .. (k+1)*PASSES_PER_TASK-1 with --estimator pppm) and a
#                        merge job after it (afterok) that writes RUN/image.exr and RUN/run.json
#   make slurm-status    which tasks of RUN are done, queued or missing
#   make slurm-resubmit  submit only the missing tasks of RUN (a failed or cancelled task), and the merge
#   make slurm-local     the same tasks and merge on this machine with make -j JOBS (no Slurm)
# Variables: RUN (the run folder, on a file system all nodes share; default OUT/slurm-SCENE),
# TASKS (4), PASSES_PER_TASK (16), PHOTONS (100000), SEED (1), ALPHA (0.7), RADIUS (0 = automatic),
# CPUS_PER_TASK (1), PARTITION, TIME_LIMIT (per task, e.g. 30:00), MEM (per task, e.g. 2G),
# FANIN (parts merged at once, default 64; more are merged as a tree), and for the scene SCENE,
# WIDTH, HEIGHT, BAKE_FLAGS as for `make render`. The build (BUILD) must be on the shared file system.
RUN             ?= $(OUT)/slurm-$(SCENE_NAME)
TASKS           ?= 4
PASSES_PER_TASK ?= 16
PHOTONS         ?= 100000
SEED            ?= 1
ALPHA           ?= 0.7
RADIUS          ?= 0
CPUS_PER_TASK   ?= 1
PARTITION       ?=
TIME_LIMIT      ?=
MEM             ?=
FANIN           ?= 64
SLURM_SUBMIT = pipelines/slurm/submit.sh --scene $(OUT)/$(SCENE_NAME)/scene.h5 --out $(RUN) \
  --bin $(BIN) --tasks $(TASKS) --passes-per-task $(PASSES_PER_TASK) --photons $(PHOTONS) \
  --seed $(SEED) --alpha $(ALPHA) --radius $(RADIUS) --cpus-per-task $(CPUS_PER_TASK) \
  --fanin $(FANIN) $(if $(PARTITION),--partition $(PARTITION)) \
  $(if $(TIME_LIMIT),--time $(TIME_LIMIT)) $(if $(MEM),--mem $(MEM))
.PHONY: slurm-help slurm-render slurm-status slurm-resubmit slurm-local slurm-scene
slurm-help:
	@sed -n '/^# On a Slurm cluster/,/^RUN /p' Makefile | sed '$$d; s/^# \{0,1\}//'

slurm-scene: build-tools
	@$(MAKE) --no-print-directory -f pipelines/render.mk BIN=$(BIN) SCENE=$(SCENE) OUT=$(OUT) \
	  $(OUT)/$(SCENE_NAME)/scene.h5

slurm-render: slurm-scene
	@$(SLURM_SUBMIT)

slurm-status:
	@pipelines/slurm/resubmit.sh --status $(RUN)

slurm-resubmit:
	@pipelines/slurm/resubmit.sh $(RUN)

slurm-local: slurm-scene
	@[ -f $(RUN)/run.env ] || $(SLURM_SUBMIT) --prepare-only
	@$(MAKE) --no-print-directory -j$(JOBS) -f pipelines/slurm/local.mk RUN=$(RUN)
