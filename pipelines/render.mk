# render.mk — the default render's stage DAG; intermediates under $(OUT)/$(SCENE_NAME)/: SCENE is
# a name in data/ or a path to any scene file scene-bake reads (pipelines/scene.mk).
#
# ESTIMATOR=auto (render's default, pppm), sppm or pppm: a new eye pass every pass (sppm.h), so light outlines,
# edges and glass converge. Their state is per pixel and their passes are short, so the DAG is
#
#   scene-bake → render --estimator sppm|pppm (every pass: eye pass, photons, gather)
#
# with a checkpoint every CHECKPOINT_EVERY passes: interrupting `make render` and running it
# again resumes. (The same passes stage by stage: trace-hitpoints --pass p, trace-photons
# --first-pass p, illuminate --estimator sppm --state; README.) Intermediates: scene.h5 and the
# checkpoint (one hitpoint or three sums per pixel).
#
# ESTIMATOR=ppm: progressive photon mapping with one fixed eye pass, stage by stage:
#
#   scene-bake → trace-hitpoints → trace-photons → build-grid → illuminate → synthesize
#
# Every stage's parameters go into a stamp file (pipelines/stamp.mk) that the stage depends on:
# running again with the same inputs and parameters does nothing, and changing one stage's
# parameter reruns that stage and the stages after it, no others.
#
# Long runs (PASSES > STAGED_MAX_PASSES) use the render driver instead: the same stage functions in
# one process, with a checkpoint every CHECKPOINT_EVERY passes; interrupting `make render` and
# running it again resumes from the checkpoint.
#
# Variables (defaults below): SCENE (a name in data/ or a path; pipelines/scene.mk), OUT, BIN, WIDTH, HEIGHT, PASSES, PHOTONS, ALPHA, SEED, SPP,
# DIRECT (photons | shadow-rays), RADIUS (0 = automatic), METHOD (grid | flann on DEVICE=cpu; an
# OpenCL gather of gather_method.h, e.g. grid-kmeans, with DEVICE=opencl), DEVICE (cpu | opencl |
# auto), MAX_BINS, WG (work-group size of the clusters), EXPOSURE, BAKE_FLAGS (extra scene-bake
# options, after the scene's own NAME.bake-options file, which scene-bake reads: pipelines/scene.mk;
# SCENE_BAKE_OPTIONS= reads none), THREADS. With ESTIMATOR=ppm the clustered OpenCL methods add the
# cluster stage to the DAG (clusters.h5); the other estimators go through the render driver, which
# ignores METHOD.
BIN        ?= build/bin
SCENE      ?= cornell-box
OUT        ?= out
WIDTH      ?= 512
HEIGHT     ?= 512
# ESTIMATOR, DIRECT, PHOTONS and RADIUS default to render's own defaults (render_defaults.h, chosen
# by measurement: docs/RESULTS.md "Defaults"): ESTIMATOR=auto passes no --estimator, so render
# uses its own (pppm); shadow-rays, and the photons per pass and initial radius chosen from the
# scene (auto, 0), by render and trace-photons alike.
ESTIMATOR  ?= auto
PASSES     ?= $(if $(filter ppm,$(ESTIMATOR)),16,200)
PHOTONS    ?= auto
ALPHA      ?= 0.7
SEED       ?= 1
SPP        ?= 1
DIRECT     ?= shadow-rays
RADIUS     ?= 0
DEVICE     ?= cpu
METHOD     ?= $(if $(filter cpu,$(DEVICE)),grid,hash-grid)
WG         ?= 64
MAX_BINS   ?= 64
EXPOSURE   ?= 0
BAKE_FLAGS ?=
THREADS    ?= 0
STAGED_MAX_PASSES ?= 32
CHECKPOINT_EVERY  ?= 10
include pipelines/scene.mk
DIR := $(OUT)/$(SCENE_NAME)

include pipelines/stamp.mk

ifeq ($(SCENE_FILE),)
$(error no file '$(SCENE)' and no scene named '$(SCENE)' in data/ (looked for .dae .obj .gltf .glb .ply); give SCENE=path/to/file or a name in data/)
endif

# scene-bake reads the scene's options file itself (SCENE_OPTIONS_ARG, pipelines/scene.mk) and
# puts its options before these, so WIDTH, HEIGHT and BAKE_FLAGS win over the file's.
BAKE_P  := --width $(WIDTH) --height $(HEIGHT) $(SCENE_OPTIONS_ARG) $(BAKE_FLAGS)
EYE_P   := --spp $(SPP) --direct $(DIRECT) --radius $(RADIUS) --seed $(SEED)
PHOT_P  := --passes $(PASSES) --photons $(PHOTONS) --seed $(SEED)
GRID_P  := --max-bins $(MAX_BINS)
ILL_P   := --alpha $(ALPHA) --method $(METHOD) --max-bins $(MAX_BINS) --device $(DEVICE) \
           $(if $(filter-out cpu,$(DEVICE)),--work-group $(WG))
# Clusters read by the clustered methods (gather_method.h).
CLUSTER_KIND := $(if $(filter kmeans-clusters grid-kmeans,$(METHOD)),kmeans,$(if $(filter grid-gridclusters,$(METHOD)),grid))
CLU_P   := --method $(CLUSTER_KIND) --wg-size $(WG)
SYN_P   := --exposure $(EXPOSURE)
T       := --threads $(THREADS)

.PHONY: render
ifneq ($(ESTIMATOR),ppm)
render: $(DIR)/render.exr
	@echo "render: $(DIR)/render.exr ($(ESTIMATOR), $(PASSES) passes, render driver)"
else ifeq ($(shell test $(PASSES) -gt $(STAGED_MAX_PASSES) && echo driver),driver)
render: $(DIR)/render.exr
	@echo "render: $(DIR)/render.exr ($(PASSES) passes, render driver)"
else
render: $(DIR)/image.exr
	@echo "render: $(DIR)/image.exr ($(PASSES) passes, staged)"
endif

# scene.d (scene-bake --depfile): every file the last bake read (its buffers, textures, inserts,
# environment map), so editing any of them bakes again; absent before the first bake.
$(DIR)/scene.h5: $(SCENE_FILE) $(SCENE_BAKE_OPTIONS) $(BIN)/scene-bake $(call param_stamp,$(DIR)/bake.params,$(BAKE_P))
	$(BIN)/scene-bake $(SCENE_FILE) -o $@ $(BAKE_P) --depfile $(DIR)/scene.d
-include $(DIR)/scene.d

$(DIR)/hitpoints.h5: $(DIR)/scene.h5 $(BIN)/trace-hitpoints $(call param_stamp,$(DIR)/eye.params,$(EYE_P))
	$(BIN)/trace-hitpoints --scene $< -o $@ --estimator ppm $(EYE_P) $(T)

$(DIR)/photons.h5: $(DIR)/scene.h5 $(BIN)/trace-photons $(call param_stamp,$(DIR)/photons.params,$(PHOT_P))
	$(BIN)/trace-photons --scene $< -o $@ $(PHOT_P) $(T)

ifeq ($(METHOD),grid)
$(DIR)/grid.h5: $(DIR)/photons.h5 $(DIR)/hitpoints.h5 $(BIN)/build-grid $(call param_stamp,$(DIR)/grid.params,$(GRID_P))
	$(BIN)/build-grid --scene $(DIR)/scene.h5 --photons $(DIR)/photons.h5 --hitpoints $(DIR)/hitpoints.h5 -o $@ $(GRID_P)

$(DIR)/state.h5: $(DIR)/hitpoints.h5 $(DIR)/grid.h5 $(BIN)/illuminate $(call param_stamp,$(DIR)/illuminate.params,$(ILL_P))
	$(BIN)/illuminate --scene $(DIR)/scene.h5 --hitpoints $(DIR)/hitpoints.h5 --grid $(DIR)/grid.h5 -o $@ --estimator ppm $(ILL_P) $(T)
else ifneq ($(CLUSTER_KIND),)
$(DIR)/clusters.h5: $(DIR)/hitpoints.h5 $(BIN)/cluster $(call param_stamp,$(DIR)/cluster.params,$(CLU_P))
	$(BIN)/cluster --scene $(DIR)/scene.h5 --hitpoints $(DIR)/hitpoints.h5 -o $@ $(CLU_P) $(T)

$(DIR)/state.h5: $(DIR)/hitpoints.h5 $(DIR)/photons.h5 $(DIR)/clusters.h5 $(BIN)/illuminate $(call param_stamp,$(DIR)/illuminate.params,$(ILL_P))
	$(BIN)/illuminate --scene $(DIR)/scene.h5 --hitpoints $(DIR)/hitpoints.h5 --photons $(DIR)/photons.h5 --clusters $(DIR)/clusters.h5 -o $@ --estimator ppm $(ILL_P) $(T)
else
$(DIR)/state.h5: $(DIR)/hitpoints.h5 $(DIR)/photons.h5 $(BIN)/illuminate $(call param_stamp,$(DIR)/illuminate.params,$(ILL_P))
	$(BIN)/illuminate --scene $(DIR)/scene.h5 --hitpoints $(DIR)/hitpoints.h5 --photons $(DIR)/photons.h5 -o $@ --estimator ppm $(ILL_P) $(T)
endif

$(DIR)/image.exr: $(DIR)/state.h5 $(BIN)/synthesize $(call param_stamp,$(DIR)/synthesize.params,$(SYN_P))
	$(BIN)/synthesize --hitpoints $< -o $@ $(SYN_P)

# The driver's parameters are all of the above in one stamp; its checkpoint makes reruns resume.
# render --resume refuses a checkpoint made with other state options (render_driver.h
# state_parameters), so one older than their own stamp (or than the scene) is removed first: a
# rerun after e.g. an ALPHA change starts afresh, one after a PASSES change (or an interruption)
# resumes.
# sppm and pppm gather through the CPU grid of each pass (DEVICE=opencl traces their eye and
# photon passes on the device), so they take no --method.
DRIVER_ILL_P := $(if $(filter ppm,$(ESTIMATOR)),$(ILL_P),--alpha $(ALPHA) --max-bins $(MAX_BINS) --device $(DEVICE))
ESTIMATOR_P := $(if $(filter auto,$(ESTIMATOR)),,--estimator $(ESTIMATOR))
DRIVER_P := $(EYE_P) $(ESTIMATOR_P) --passes $(PASSES) --photons $(PHOTONS) $(DRIVER_ILL_P) $(SYN_P)
STATE_P  := $(EYE_P) $(ESTIMATOR_P) --photons $(PHOTONS) --alpha $(ALPHA)
CHECKPOINT := $(DIR)/render-checkpoint.h5
$(DIR)/render.exr: $(DIR)/scene.h5 $(BIN)/render $(call param_stamp,$(DIR)/render.params,$(DRIVER_P)) \
                   $(call param_stamp,$(DIR)/render-state.params,$(STATE_P))
	@[ $(CHECKPOINT) -nt $(DIR)/render-state.params ] && [ $(CHECKPOINT) -nt $< ] || rm -f $(CHECKPOINT)
	$(BIN)/render --scene $< -o $@ $(DRIVER_P) $(T) \
	  --checkpoint $(CHECKPOINT) --checkpoint-every $(CHECKPOINT_EVERY) --resume
