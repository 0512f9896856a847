# bench.mk — the benchmarks of docs/BENCHMARKS.md, each writing its table to $(OUT)/bench/.
#
#   make bench                    all of them (the whole target has not been timed; gather alone
#                                 = bench_gather --runs 5: 8 min 25 s on 2 idle cores, the
#                                 Table 7.3 run of docs/BENCHMARKS.md)
#   make bench BENCH=raycast      one: raycast | pipeline | memory | opencl | gather
#
# Results are measured numbers for this machine; copy them into docs/BENCHMARKS.md by hand with the
# machine's description (nproc, lscpu model name, OpenCL device). Meshes from ../shared/scenes are
# used when present (MESH=path overrides; the table says when none was found).
BIN   ?= build/bin
OUT   ?= out
BENCH ?= raycast pipeline memory opencl gather
MESH  ?= $(firstword $(wildcard ../shared/scenes/stanford-bunny.obj))
DIR   := $(OUT)/bench

.PHONY: bench $(BENCH)
bench: $(BENCH)
	@echo "bench: tables in $(DIR)/"

$(DIR):
	@mkdir -p $@

raycast: | $(DIR)
	$(BIN)/bench_raycast $(if $(MESH),--mesh $(MESH)) | tee $(DIR)/raycast.md

pipeline: | $(DIR)
	$(BIN)/bench_pipeline | tee $(DIR)/pipeline.md

# Peak memory after 10 and after 1,000 passes, in separate processes (the peak is monotonic).
memory: | $(DIR)
	$(BIN)/bench_pipeline --memory-passes 10 | tee $(DIR)/memory-10.md
	$(BIN)/bench_pipeline --memory-passes 1000 | tee $(DIR)/memory-1000.md

opencl: | $(DIR)
	$(BIN)/bench_opencl | tee $(DIR)/opencl.md

# Thesis Tables 7.3-7.5: every gather method, k-means vs grid clusters, fillers.
gather: | $(DIR)
	$(BIN)/bench_gather | tee $(DIR)/gather.md
