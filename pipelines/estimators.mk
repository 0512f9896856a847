# estimators.mk — the estimators with a new eye pass every pass against the fixed one and against
# path tracing, over ALL pixels (lights included) and over the pixels that see no emitter, at equal
# rendering time; and SPPM's error against passes (does it reach a floor?). docs/RESULTS.md section
# "A new eye pass every pass: SPPM and probabilistic PPM" quotes the report
# (docs/results/estimators.md).
#
#   make -f pipelines/estimators.mk                      all: TIME s per run, 512×512 (long: the
#                                                         references take REF_PARTS × REF_TIME per scene)
#   make -f pipelines/estimators.mk W=256 H=256 TIME=10 REF_TIME=120   a smaller, faster run
#
# Per scene of SCENES:
#   ref.exr, ref2.exr … ref<N>.exr   N = REF_PARTS_<scene> independent reference parts of REF_TIME
#                      seconds each, seeds REF_SEED … REF_SEED+N−1: path tracing for the diffuse box
#                      (unbiased), SPPM elsewhere (path tracing's caustics and SDS paths converge too
#                      slowly). The reference is their mean (bench/estimators.py); the spread of
#                      the parts estimates its own error (its noise; a bias common to all parts is
#                      not seen), and the report prints it beside the figures it is compared with.
#                      More parts cost REF_TIME each and keep the parts already rendered.
#   pt, ppm, ppm-spp4, sppm, pppm   TIME seconds of rendering each (pathtrace --time,
#                      render --time; program start and file writes excluded by both), seed SEED.
#   sppm-passes        SPPM for CURVE_PASSES passes with snapshots: error against passes.
#   ppm-passes         the same for PPM's fixed eye pass, whose outline pixels never converge: the
#                      floor fits of the report are checked on an estimator known to have one.
# The runs go one after another (.NOTPARALLEL); each records the load average before and after.
BUILD  ?= build
BIN    ?= $(BUILD)/bin
OUT    ?= out
RES    ?= docs/results
PY     ?= /usr/bin/python3
DIR    := $(OUT)/estimators
SCENES ?= cornell-box cornell-spheres sds-pool
W      ?= 512
H      ?= 512
TIME   ?= 30
REF_TIME ?= 600
PHOTONS  ?= 100000
PPM_SPP  ?= 4
SEED     ?= 1
REF_SEED ?= 1001
MASK_SPP ?= 256
THREADS  ?= 0
CURVE_PASSES ?= 1000
REF_KIND_cornell-box     ?= pt
REF_KIND_cornell-spheres ?= sppm
REF_KIND_sds-pool        ?= sppm
# Reference parts per scene: enough that the mean's own error is under a quarter of the SPPM error
# it is compared with (measured at 512×512, TIME=30, REF_TIME=300; docs/RESULTS.md "A new eye pass every pass").
REF_PARTS ?= 2
REF_PARTS_cornell-box     ?= 8
REF_PARTS_cornell-spheres ?= 4
REF_PARTS_sds-pool        ?= 4
ref_parts = $(or $(REF_PARTS_$(1)),$(REF_PARTS))

include pipelines/stamp.mk

LOAD = cat /proc/loadavg >>
T    := --threads $(THREADS)
SHELL := /bin/bash
.SHELLFLAGS := -o pipefail -c
.NOTPARALLEL:
.PHONY: all runs report
all: report

METHODS := pt ppm ppm-spp4 sppm pppm
RUNS :=

# Snapshot passes about √2 apart, and the last.
snaps = $(shell awk -v n=$(1) 'BEGIN { p = 1; s = ""; last = 0; \
  while (p <= n) { q = int(p + 0.5); if (q > last) { s = s (s == "" ? "" : ",") q; last = q } p *= sqrt(2) } \
  if (last < n) s = s "," n; print s }')

# $(1) = scene
define SCENE_RULES
$(DIR)/$(1)/scene.h5: data/$(1).dae $(call param_stamp,$(DIR)/$(1)/.bake,$(W) $(H))
	$(BIN)/scene-bake data/$(1).dae -o $$@ --width $(W) --height $(H) > /dev/null

$(DIR)/$(1)/mask.exr: $(DIR)/$(1)/scene.h5 $(call param_stamp,$(DIR)/$(1)/.mask,$(MASK_SPP))
	$(BIN)/emitter-mask --scene $$< -o $$@ --spp $(MASK_SPP) > /dev/null

# References: part 1 is ref.exr (seed REF_SEED), part i > 1 is ref<i>.exr (seed REF_SEED + i − 1).
$(DIR)/$(1)/ref.exr: $(DIR)/$(1)/scene.h5 $(call param_stamp,$(DIR)/$(1)/.ref,$(REF_KIND_$(1)) $(REF_TIME) $(REF_SEED) $(PHOTONS))
	$(call REF_RECIPE,$(1),$$@,$(REF_SEED))
$(foreach i,$(shell seq 2 $(call ref_parts,$(1))),$(eval $(call REF_PART_RULE,$(1),$(i))))

$(DIR)/$(1)/pt.exr: $(DIR)/$(1)/scene.h5 $(call param_stamp,$(DIR)/$(1)/.pt,$(TIME) $(SEED) $(THREADS))
	$(LOAD) $(DIR)/$(1)/runs.load
	$(BIN)/pathtrace --scene $$< -o $$@ --png none --spp 1000000 --time $(TIME) --seed $(SEED) \
	  --stats $(DIR)/$(1)/pt.json $(T) | tail -1
	$(LOAD) $(DIR)/$(1)/runs.load
$(DIR)/$(1)/ppm.exr: $(DIR)/$(1)/scene.h5 $(call param_stamp,$(DIR)/$(1)/.ppm,$(TIME) $(SEED) $(THREADS) $(PHOTONS))
	$(call RENDER_RECIPE,$(1),ppm,--estimator ppm --spp 1)
$(DIR)/$(1)/ppm-spp4.exr: $(DIR)/$(1)/scene.h5 $(call param_stamp,$(DIR)/$(1)/.ppm-spp4,$(TIME) $(SEED) $(THREADS) $(PHOTONS) $(PPM_SPP))
	$(call RENDER_RECIPE,$(1),ppm-spp4,--estimator ppm --spp $(PPM_SPP))
$(DIR)/$(1)/sppm.exr: $(DIR)/$(1)/scene.h5 $(call param_stamp,$(DIR)/$(1)/.sppm,$(TIME) $(SEED) $(THREADS) $(PHOTONS))
	$(call RENDER_RECIPE,$(1),sppm,--estimator sppm)
$(DIR)/$(1)/pppm.exr: $(DIR)/$(1)/scene.h5 $(call param_stamp,$(DIR)/$(1)/.pppm,$(TIME) $(SEED) $(THREADS) $(PHOTONS))
	$(call RENDER_RECIPE,$(1),pppm,--estimator pppm)

# SPPM and PPM against passes: snapshots about √2 apart up to CURVE_PASSES.
$(foreach e,sppm ppm,$(eval $(call CURVE_RULE,$(1),$(e))))

REFS_$(1) := $(DIR)/$(1)/ref.exr $(foreach i,$(shell seq 2 $(call ref_parts,$(1))),$(DIR)/$(1)/ref$(i).exr)
RUNS += $(foreach m,$(METHODS),$(DIR)/$(1)/$(m).exr) $$(REFS_$(1)) \
        $(DIR)/$(1)/mask.exr $(DIR)/$(1)/sppm-passes.json $(DIR)/$(1)/ppm-passes.json
endef

# $(1) = scene, $(2) = estimator
define CURVE_RULE
$(DIR)/$(1)/$(2)-passes.json: $(DIR)/$(1)/scene.h5 $(call param_stamp,$(DIR)/$(1)/.curve-$(2),$(CURVE_PASSES) $(SEED) $(THREADS) $(PHOTONS))
	@rm -rf $(DIR)/$(1)/$(2)-passes && mkdir -p $(DIR)/$(1)/$(2)-passes
	$(BIN)/render --scene $$< -o $(DIR)/$(1)/$(2)-passes/final.exr --estimator $(2) --direct photons \
	  --passes $(CURVE_PASSES) --photons $(PHOTONS) --seed $(SEED) \
	  --snapshot-at $(call snaps,$(CURVE_PASSES)) --snapshot '$(DIR)/$(1)/$(2)-passes/{pass}.exr' \
	  --stats $$@ $(T) | tail -1
endef

# $(1) = scene, $(2) = part number > 1
define REF_PART_RULE
$(DIR)/$(1)/ref$(2).exr: $(DIR)/$(1)/scene.h5 $(call param_stamp,$(DIR)/$(1)/.ref$(2),$(REF_KIND_$(1)) $(REF_TIME) $(REF_SEED) $(PHOTONS))
	$$(call REF_RECIPE,$(1),$$@,$$$$(($(REF_SEED) + $(2) - 1)))
endef

# $(1) = scene, $(2) = output, $(3) = seed
define REF_RECIPE
	$(LOAD) $(DIR)/$(1)/ref.load
	$(if $(filter pt,$(REF_KIND_$(1))),$(BIN)/pathtrace --scene $(DIR)/$(1)/scene.h5 -o $(2) --png none \
	  --spp 100000000 --time $(REF_TIME) --seed $(3) $(T) | tail -1,$(BIN)/render \
	  --scene $(DIR)/$(1)/scene.h5 -o $(2) --estimator sppm --direct photons --time $(REF_TIME) \
	  --photons $(PHOTONS) --seed $(3) $(T) | tail -1)
	$(LOAD) $(DIR)/$(1)/ref.load
endef

# $(1) = scene, $(2) = run name, $(3) = render options
define RENDER_RECIPE
	$(LOAD) $(DIR)/$(1)/runs.load
	$(BIN)/render --scene $(DIR)/$(1)/scene.h5 -o $(DIR)/$(1)/$(2).exr $(3) --direct photons --time $(TIME) \
	  --photons $(PHOTONS) --seed $(SEED) --stats $(DIR)/$(1)/$(2).json $(T) | tail -1
	$(LOAD) $(DIR)/$(1)/runs.load
endef

$(foreach s,$(SCENES),$(eval $(call SCENE_RULES,$(s))))

runs: $(RUNS)

report: $(RES)/estimators.md
$(RES)/estimators.md: $(RUNS) bench/estimators.py
	@mkdir -p $(RES)
	$(PY) bench/estimators.py --dir $(DIR) --imgcompare $(BIN)/imgcompare --scenes "$(SCENES)" \
	  --methods "$(METHODS)" --ref-parts "$(foreach s,$(SCENES),$(s)=$(call ref_parts,$(s)))" --settings "W=$(W) H=$(H) TIME=$(TIME) REF_TIME=$(REF_TIME) \
	  PHOTONS=$(PHOTONS) PPM_SPP=$(PPM_SPP) SEED=$(SEED) REF_SEED=$(REF_SEED) THREADS=$(THREADS) \
	  CURVE_PASSES=$(CURVE_PASSES)$(foreach s,$(SCENES), REF_PARTS_$(s)=$(call ref_parts,$(s)))" -o $@
