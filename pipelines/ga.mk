# ga.mk — evolutionary clustering of hitpoints (thesis ch. 8): the thesis's Tables
# 8.1–8.4 on this machine, and the staged route that precomputes GA clusters once for a static
# scene and camera and reuses them.
#
#   make -f pipelines/ga.mk                  both (tables: 50 min wall on 2 cores, 43 of them Table 8.4,
#                                            in the run of docs/results/ga.md)
#   make -f pipelines/ga.mk tables           Tables 8.1–8.4 + rank correlations → docs/results/ga-tables.md
#   make -f pipelines/ga.mk stages           scene → hitpoints → photon distribution → cluster --method ga
#                                            → illuminate --method grid-kmeans --clusters → image
#   make -f pipelines/ga.mk tables RUNS=3 ITERATIONS=1000 BUILD=build-ga
#
# tables: bench_ga (bench/bench_ga.cpp) at SIZE, hitpoints of MESH (the thesis: the floor), a map
# of DIST_PASSES passes, RUNS runs of ITERATIONS generations × POPULATION per CPU fitness, and
# DEVICE_FITNESS_RUNS runs of the device-time fitness (DEVICE_ITERATIONS × DEVICE_POPULATION,
# DEVICE_RUNS gathers per evaluation: the thesis's 10 runs of 300 × 50, 43 minutes on PoCL
# with 2 cores in the run of docs/results/ga.md; DEVICE_FITNESS_RUNS=0 leaves Table 8.4 out).
# The table is measured again when bench_ga changed or a parameter did.
#
# stages: every stage's parameters go into a stamp (pipelines/stamp.mk) as in render.mk: the GA
# (minutes) reruns only when its inputs or parameters change; an interrupted `cluster` resumes from
# its checkpoint ($(DIR)/clusters.h5.checkpoint.h5) when make runs it again.
BUILD       ?= build
BIN         ?= $(BUILD)/bin
OUT         ?= out
RES         ?= docs/results
SCENE       ?= cornell-box
# SCENE goes into recipes: only a name make can pass safely (pipelines/names.mk).
include pipelines/names.mk
$(call pf_check_name,SCENE)
SCENE_FILE  ?= data/$(SCENE).dae
SIZE        ?= 320x280
MESH        ?= floor
PHOTONS     ?= 100000
DIST_PASSES ?= 1000
FITNESS     ?= filler,grid-bins,memory-access,work
RUNS        ?= 10
ITERATIONS  ?= 3000
POPULATION  ?= 50
DEVICE_FITNESS_RUNS ?= 10
DEVICE_ITERATIONS   ?= 300
DEVICE_POPULATION   ?= 50
DEVICE_RUNS ?= 5
TIME_ROUNDS ?= 25
WG          ?= 64
THREADS     ?= 0
# stages: the fitness of the cached clusters, and the render's passes.
GA_FITNESS  ?= work
PASSES      ?= 4
DIR         := $(OUT)/ga

include pipelines/stamp.mk

WIDTH  := $(word 1,$(subst x, ,$(SIZE)))
HEIGHT := $(word 2,$(subst x, ,$(SIZE)))

.PHONY: all tables stages FORCE
all: tables stages
tables: $(RES)/ga-tables.md
stages: $(DIR)/image.exr

$(DIR) $(RES):
	@mkdir -p $@

# cmake decides whether a binary is out of date; its timestamp changes only when it was rebuilt.
$(BIN)/bench_ga $(BIN)/scene-bake $(BIN)/trace-hitpoints $(BIN)/trace-photons \
$(BIN)/photon-distribution $(BIN)/cluster $(BIN)/illuminate $(BIN)/synthesize: FORCE
	@cmake --build $(BUILD) --target $(notdir $@) > /dev/null

BENCH_P := --size $(SIZE) --mesh $(MESH) --photons $(PHOTONS) --dist-passes $(DIST_PASSES) \
           --fitness $(FITNESS) --runs $(RUNS) --iterations $(ITERATIONS) \
           --population $(POPULATION) --device-fitness-runs $(DEVICE_FITNESS_RUNS) \
           --device-iterations $(DEVICE_ITERATIONS) --device-population $(DEVICE_POPULATION) \
           --device-runs $(DEVICE_RUNS) --time-rounds $(TIME_ROUNDS) --wg-size $(WG) \
           --threads $(THREADS) --dae $(SCENE_FILE)

$(RES)/ga-tables.md: $(BIN)/bench_ga $(call param_stamp,$(DIR)/bench.params,$(BENCH_P)) | $(RES)
	$(BIN)/bench_ga $(BENCH_P) > $@.tmp
	@mv $@.tmp $@

# ---- the staged route ----
BAKE_P := --width $(WIDTH) --height $(HEIGHT)
DIST_P := --passes $(DIST_PASSES) --emit $(PHOTONS)
CLU_P  := --method ga --fitness $(GA_FITNESS) --wg-size $(WG) --population $(POPULATION) \
          --ga-iterations $(ITERATIONS)
PHOT_P := --passes $(PASSES) --photons $(PHOTONS)
ILL_P  := --device opencl --work-group $(WG) --method grid-kmeans
T      := --threads $(THREADS)

$(DIR)/scene.h5: $(SCENE_FILE) $(BIN)/scene-bake $(call param_stamp,$(DIR)/bake.params,$(BAKE_P)) | $(DIR)
	$(BIN)/scene-bake $(SCENE_FILE) -o $@ $(BAKE_P)

$(DIR)/hitpoints.h5: $(DIR)/scene.h5 $(BIN)/trace-hitpoints
	$(BIN)/trace-hitpoints --scene $< -o $@ --estimator ppm --direct photons $(T)

$(DIR)/distribution.h5: $(DIR)/hitpoints.h5 $(BIN)/photon-distribution $(call param_stamp,$(DIR)/dist.params,$(DIST_P))
	$(BIN)/photon-distribution --scene $(DIR)/scene.h5 --hitpoints $< -o $@ $(DIST_P) $(T)

# Resumes an interrupted evolution; a checkpoint of other inputs or parameters is refused (exit 2),
# then it is deleted and the evolution starts afresh.
CLUSTER = $(BIN)/cluster --scene $(DIR)/scene.h5 --hitpoints $(DIR)/hitpoints.h5 \
          --distribution $(DIR)/distribution.h5 -o $@ $(CLU_P) $(T)
$(DIR)/clusters.h5: $(DIR)/hitpoints.h5 $(DIR)/distribution.h5 $(BIN)/cluster $(call param_stamp,$(DIR)/cluster.params,$(CLU_P))
	$(CLUSTER) --resume || { rc=$$?; [ $$rc -eq 2 ] && rm -f $@.checkpoint.h5 && $(CLUSTER); }

$(DIR)/photons.h5: $(DIR)/scene.h5 $(BIN)/trace-photons $(call param_stamp,$(DIR)/photons.params,$(PHOT_P))
	$(BIN)/trace-photons --scene $< -o $@ $(PHOT_P) $(T)

$(DIR)/state.h5: $(DIR)/hitpoints.h5 $(DIR)/photons.h5 $(DIR)/clusters.h5 $(BIN)/illuminate $(call param_stamp,$(DIR)/illuminate.params,$(ILL_P))
	$(BIN)/illuminate --scene $(DIR)/scene.h5 --hitpoints $< --photons $(DIR)/photons.h5 \
	  --clusters $(DIR)/clusters.h5 -o $@ --estimator ppm $(ILL_P) $(T)

$(DIR)/image.exr: $(DIR)/state.h5 $(BIN)/synthesize
	$(BIN)/synthesize --hitpoints $< -o $@
