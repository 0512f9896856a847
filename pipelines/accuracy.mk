# accuracy.mk — speed against accuracy (docs/RESULTS.md "Speed against accuracy"): image error
# against a long reference as a function of wall time and of passes, for every bundled scene and
# every method:
#
#   pt        path tracing (`pathtrace`), snapshots every PT_EVERY samples per pixel
#   ppm       progressive photon mapping on the CPU (`render --method grid`, α = 0.7) with
#             EYE_SPP_<scene> eye samples per pixel (more for glass and water: the eye pass draws
#             the reflect-or-refract choice once per sample for the whole run, docs/PATHTRACE.md)
#   ppm-a<α>  the α sweep: the same on the CPU, one run per α of ALPHAS, SWEEP_EYE_SPP eye samples
#   sppm, pppm  the estimators with a new eye pass every pass (sppm.h; `render --estimator E`,
#             α = 0.7, their defaults: one eye sample per pixel and pass, Sobol pixel sampler,
#             slab 0.25), PASSES × PHOTONS as PPM; one per ESTIMATORS
#   cl-<m>    PPM on OpenCL (`render --device opencl --method m`) for each m of CL_METHODS
#   classic   classic photon mapping (`trace-photons` + `illuminate --estimator classic`), one
#             image per photon-map size of CLASSIC_PHOTONS and k of CLASSIC_K
#
# References (REF_KIND_<scene>):
#   pt   the diffuse Cornell box: `pathtrace` with REF_SPP samples per pixel (unbiased);
#   ppm  the caustic and SDS scenes: a long PPM run (REF_PASSES × REF_PHOTONS photons, REF_EYE_SPP
#        eye samples per pixel), because path tracing's caustics (L S+ D E) and SDS paths converge
#        far too slowly to make a reference in this budget; docs/RESULTS.md explains.
#   Every reference uses seed REF_SEED, the test runs SEED: their random numbers are independent.
# `refcheck` renders the PPM reference recipe on the diffuse box too and compares it with the path
# traced reference: the bias a PPM reference of that length carries.
#
# Errors are imgcompare's metrics over the pixels that see no emitter (emitter-mask, the mask's
# reasons in libcommon/photonflow/stages/emitter_mask.h). The runs go one after another (.NOTPARALLEL)
# so that their wall times do not disturb each other; each run records the load average before
# and after. bench/accuracy.py collects the metrics into TSV files and draws the charts.
#
#   make -f pipelines/accuracy.mk BUILD=build-acc                 all (about 10 minutes on 2 cores)
#   make -f pipelines/accuracy.mk BUILD=build-acc report          charts and tables only
#   make -f pipelines/accuracy.mk BUILD=build-acc SCENES=sds-pool one scene
#   make -B -f pipelines/accuracy.mk ...                          measure everything again
#
# Scaling up (a quiet machine, a GPU): raise W, H, PASSES, PHOTONS, PT_SPP, REF_SPP, REF_PASSES
# together; keep REF_PASSES × REF_PHOTONS several times PASSES × PHOTONS (6× by default) and
# REF_SPP ≥ 4 × PT_SPP, and check the table "The references' own error" of the report: its E must
# stay well below the errors compared (docs/RESULTS.md).
# Changing a parameter reruns only the runs it affects (parameter stamps, pipelines/stamp.mk).
# The runs do not depend on the tools' binaries (a rebuild after an unrelated edit would rerun the
# whole 8.6 minutes): after a change to the renderer, measure again with make -B.
BUILD  ?= build
BIN    ?= $(BUILD)/bin
OUT    ?= out
RES    ?= docs/results
PY     ?= /usr/bin/python3
DIR    := $(OUT)/accuracy
SCENES ?= cornell-box cornell-spheres sds-pool
W      ?= 128
H      ?= 128
# Threads of the timed runs, and of the references and masks (not timed; 0 = all cores).
# One thread by default: on cores shared with other jobs, fork–join code stalls at every barrier
# whose threads are not all running, and PPM passes (several short parallel loops) lose far more
# to that than path tracing (one long loop per pass), which would bias the comparison
# (docs/RESULTS.md). THREADS also caps PoCL's worker threads (POCL_MAX_PTHREAD_COUNT).
THREADS ?= 1
REF_THREADS ?= 0
SEED   ?= 1
# Path tracing: samples per pixel, snapshot interval.
PT_SPP   ?= 1024
PT_EVERY ?= 8
# PPM test runs (CPU and OpenCL): photons per pass, passes, eye samples per pixel (per scene;
# the α sweep uses SWEEP_EYE_SPP on every scene).
PHOTONS  ?= 20000
PASSES   ?= 256
EYE_SPP_cornell-box     ?= 4
EYE_SPP_cornell-spheres ?= 16
EYE_SPP_sds-pool        ?= 16
SWEEP_EYE_SPP ?= 4
ALPHAS   ?= 0.5 0.6 0.7 0.8 0.9
CL_METHODS ?= hash-grid grid-kmeans
ESTIMATORS ?= sppm pppm
CL_PASSES  ?= 64
# Classic photon mapping: photons emitted into the map, k nearest.
CLASSIC_PHOTONS ?= 25000 100000 400000
CLASSIC_K       ?= 10 50 200
# References.
REF_SEED    ?= 1001
REF_SPP     ?= 4096
REF_PHOTONS ?= 200000
REF_PASSES  ?= 150
REF_EYE_SPP ?= 64
MASK_SPP    ?= 1024
REF_KIND_cornell-box     ?= pt
REF_KIND_cornell-spheres ?= ppm
REF_KIND_sds-pool        ?= ppm

include pipelines/stamp.mk

# Snapshot passes: about √2 apart (1, 2, 3, 4, 6, 8, 11, 16, ...), and the last pass.
snaps = $(shell awk -v n=$(1) 'BEGIN { p = 1; s = ""; last = 0; \
  while (p <= n) { q = int(p + 0.5); if (q > last) { s = s (s == "" ? "" : ",") q; last = q } p *= sqrt(2) } \
  if (last < n) s = s "," n; print s }')
LOAD = cat /proc/loadavg >>
T    := --threads $(THREADS)
TR   := --threads $(REF_THREADS)
POCL := $(if $(filter-out 0,$(THREADS)),POCL_MAX_PTHREAD_COUNT=$(THREADS))
COLLECT = $(PY) bench/accuracy.py collect --imgcompare $(BIN)/imgcompare

SHELL := /bin/bash
.SHELLFLAGS := -o pipefail -c
.NOTPARALLEL:
.PHONY: all runs report refcheck clean-results
all: report

TSVS :=

# ---- one scene ------------------------------------------------------------------------------
# $(1) = scene name
define SCENE_RULES
D_$(1) := $(DIR)/$(1)
REF_$(1) := $(DIR)/$(1)/ref.exr
MASK_$(1) := $(DIR)/$(1)/mask.exr
RUNARGS_$(1) := --reference $(DIR)/$(1)/ref.exr --mask $(DIR)/$(1)/mask.exr --scene $(1)

$(DIR)/$(1)/scene.h5: data/$(1).dae $(call param_stamp,$(DIR)/$(1)/.bake,$(W) $(H))
	$(BIN)/scene-bake data/$(1).dae -o $$@ --width $(W) --height $(H) > /dev/null

$(DIR)/$(1)/mask.exr: $(DIR)/$(1)/scene.h5 $(call param_stamp,$(DIR)/$(1)/.mask,$(MASK_SPP))
	$(BIN)/emitter-mask --scene $$< -o $$@ --spp $(MASK_SPP) $(TR)

# The reference (REF_KIND_$(1)).
$(DIR)/$(1)/ref.exr: $(DIR)/$(1)/scene.h5 \
    $(call param_stamp,$(DIR)/$(1)/.ref,$(REF_KIND_$(1)) $(REF_SEED) $(REF_SPP) $(REF_PHOTONS) $(REF_PASSES) $(REF_EYE_SPP))
	$(LOAD) $(DIR)/$(1)/ref.load
ifeq ($(REF_KIND_$(1)),pt)
	$(BIN)/pathtrace --scene $$< -o $$@ --spp $(REF_SPP) --seed $(REF_SEED) \
	  --stats $(DIR)/$(1)/ref.json $(TR) | tail -1
else
	$(BIN)/render --scene $$< -o $$@ --estimator ppm --direct photons --passes $(REF_PASSES) --photons $(REF_PHOTONS) \
	  --spp $(REF_EYE_SPP) --seed $(REF_SEED) --stats $(DIR)/$(1)/ref.json $(TR) | tail -1
endif
	$(LOAD) $(DIR)/$(1)/ref.load

# Path tracing.
$(DIR)/$(1)/pt.tsv: $(DIR)/$(1)/scene.h5 $(DIR)/$(1)/ref.exr $(DIR)/$(1)/mask.exr \
    $(call param_stamp,$(DIR)/$(1)/.pt,$(PT_SPP) $(PT_EVERY) $(SEED) $(THREADS))
	@rm -rf $(DIR)/$(1)/pt && mkdir -p $(DIR)/$(1)/pt
	$(LOAD) $(DIR)/$(1)/pt.load
	$(BIN)/pathtrace --scene $$< -o $(DIR)/$(1)/pt/final.exr --spp $(PT_SPP) --seed $(SEED) \
	  --snapshot-every $(PT_EVERY) --snapshot '$(DIR)/$(1)/pt/{spp}.exr' \
	  --stats $(DIR)/$(1)/pt.json $(T) | tail -1
	$(LOAD) $(DIR)/$(1)/pt.load
	$(COLLECT) --record $(DIR)/$(1)/pt.json --method pt --label pt $$(RUNARGS_$(1)) \
	  --load $(DIR)/$(1)/pt.load -o $$@
TSVS += $(DIR)/$(1)/pt.tsv

# Classic photon mapping: hitpoints with direct light by shadow rays (thesis ch. 3.4), one photon
# pass of N photons per map size, k nearest global photons (eq. 3.10). The time of a
# configuration is the wall time of its four processes (trace-hitpoints, trace-photons,
# illuminate, synthesize), file I/O included.
$(DIR)/$(1)/classic.tsv: $(DIR)/$(1)/scene.h5 $(DIR)/$(1)/ref.exr $(DIR)/$(1)/mask.exr \
    $(call param_stamp,$(DIR)/$(1)/.classic,$(CLASSIC_PHOTONS) / $(CLASSIC_K) $(EYE_SPP_$(1)) $(SEED) $(THREADS))
	@rm -rf $(DIR)/$(1)/classic && mkdir -p $(DIR)/$(1)/classic
	$(LOAD) $(DIR)/$(1)/classic.load
	@C=$(DIR)/$(1)/classic; \
	/usr/bin/time -f %e -o $$$$C/hp.time $(BIN)/trace-hitpoints --scene $$< -o $$$$C/hp.h5 \
	  --estimator ppm --spp $(EYE_SPP_$(1)) --direct shadow-rays --seed $(SEED) $(T) > /dev/null || exit 1; \
	for n in $(CLASSIC_PHOTONS); do \
	  /usr/bin/time -f %e -o $$$$C/ph-$$$$n.time $(BIN)/trace-photons --scene $$< \
	    -o $$$$C/ph-$$$$n.h5 --passes 1 --photons $$$$n --seed $(SEED) $(T) > /dev/null || exit 1; \
	  for k in $(CLASSIC_K); do \
	    echo "classic: $$$$n photons, k = $$$$k"; \
	    /usr/bin/time -f %e -o $$$$C/ill-$$$$n-$$$$k.time $(BIN)/illuminate --scene $$< \
	      --hitpoints $$$$C/hp.h5 --photons $$$$C/ph-$$$$n.h5 -o $$$$C/st-$$$$n-$$$$k.h5 \
	      --estimator classic -k $$$$k $(T) > /dev/null || exit 1; \
	    /usr/bin/time -f %e -o $$$$C/syn-$$$$n-$$$$k.time $(BIN)/synthesize \
	      --hitpoints $$$$C/st-$$$$n-$$$$k.h5 -o $$$$C/classic-$$$$n-$$$$k.exr > /dev/null || exit 1; \
	    rm -f $$$$C/st-$$$$n-$$$$k.h5; \
	  done; rm -f $$$$C/ph-$$$$n.h5; \
	done
	$(LOAD) $(DIR)/$(1)/classic.load
	$(COLLECT) --classic $(DIR)/$(1)/classic --method classic --label classic $$(RUNARGS_$(1)) \
	  --eye-spp $(EYE_SPP_$(1)) --load $(DIR)/$(1)/classic.load -o $$@
TSVS += $(DIR)/$(1)/classic.tsv
endef

# PPM on the CPU. $(1) = scene, $(2) = label, $(3) = α, $(4) = eye samples per pixel
define PPM_RULE
$(DIR)/$(1)/$(2).tsv: $(DIR)/$(1)/scene.h5 $(DIR)/$(1)/ref.exr $(DIR)/$(1)/mask.exr \
    $(call param_stamp,$(DIR)/$(1)/.$(2),$(3) $(PASSES) $(PHOTONS) $(4) $(SEED) $(THREADS))
	@rm -rf $(DIR)/$(1)/$(2) && mkdir -p $(DIR)/$(1)/$(2)
	$(LOAD) $(DIR)/$(1)/$(2).load
	$(BIN)/render --scene $$< -o $(DIR)/$(1)/$(2)/final.exr --estimator ppm --direct photons --alpha $(3) --method grid \
	  --passes $(PASSES) --photons $(PHOTONS) --spp $(4) --seed $(SEED) \
	  --snapshot-at $(call snaps,$(PASSES)) --snapshot '$(DIR)/$(1)/$(2)/{pass}.exr' \
	  --stats $(DIR)/$(1)/$(2).json $(T) | tail -1
	$(LOAD) $(DIR)/$(1)/$(2).load
	$(COLLECT) --record $(DIR)/$(1)/$(2).json --method $(if $(filter ppm,$(2)),ppm,ppm-sweep) \
	  --label $(2) --alpha $(3) $$(RUNARGS_$(1)) --load $(DIR)/$(1)/$(2).load -o $$@
TSVS += $(DIR)/$(1)/$(2).tsv
endef

# SPPM and PPPM on the CPU. $(1) = scene, $(2) = estimator.
define EST_RULE
$(DIR)/$(1)/$(2).tsv: $(DIR)/$(1)/scene.h5 $(DIR)/$(1)/ref.exr $(DIR)/$(1)/mask.exr \
    $(call param_stamp,$(DIR)/$(1)/.$(2),$(PASSES) $(PHOTONS) $(SEED) $(THREADS))
	@rm -rf $(DIR)/$(1)/$(2) && mkdir -p $(DIR)/$(1)/$(2)
	$(LOAD) $(DIR)/$(1)/$(2).load
	$(BIN)/render --scene $$< -o $(DIR)/$(1)/$(2)/final.exr --estimator $(2) --direct photons \
	  --passes $(PASSES) --photons $(PHOTONS) --seed $(SEED) \
	  --snapshot-at $(call snaps,$(PASSES)) --snapshot '$(DIR)/$(1)/$(2)/{pass}.exr' \
	  --stats $(DIR)/$(1)/$(2).json $(T) | tail -1
	$(LOAD) $(DIR)/$(1)/$(2).load
	$(COLLECT) --record $(DIR)/$(1)/$(2).json --method $(2) --label $(2) --alpha 0.7 \
	  $$(RUNARGS_$(1)) --load $(DIR)/$(1)/$(2).load -o $$@
TSVS += $(DIR)/$(1)/$(2).tsv
endef

# PPM on OpenCL. $(1) = scene, $(2) = OpenCL gather method. PoCL compiles a kernel for the
# device when it is first launched and caches the result on disk; a one-pass warm-up run fills
# that cache first, so the timed run measures rendering (program builds are also left out of
# the recorded seconds, RenderStatus::build_seconds).
define CL_RULE
$(DIR)/$(1)/cl-$(2).tsv: $(DIR)/$(1)/scene.h5 $(DIR)/$(1)/ref.exr $(DIR)/$(1)/mask.exr \
    $(call param_stamp,$(DIR)/$(1)/.cl-$(2),$(CL_PASSES) $(PHOTONS) $(EYE_SPP_$(1)) $(SEED) $(THREADS))
	@rm -rf $(DIR)/$(1)/cl-$(2) && mkdir -p $(DIR)/$(1)/cl-$(2)
	$(POCL) $(BIN)/render --scene $$< -o $(DIR)/$(1)/cl-$(2)/warmup.exr --estimator ppm --direct photons --device opencl --method $(2) \
	  --passes 1 --photons $(PHOTONS) --spp $(EYE_SPP_$(1)) $(T) > /dev/null 2>&1
	$(LOAD) $(DIR)/$(1)/cl-$(2).load
	$(POCL) $(BIN)/render --scene $$< -o $(DIR)/$(1)/cl-$(2)/final.exr --estimator ppm --direct photons --device opencl --method $(2) \
	  --passes $(CL_PASSES) --photons $(PHOTONS) --spp $(EYE_SPP_$(1)) --seed $(SEED) \
	  --snapshot-at $(call snaps,$(CL_PASSES)) --snapshot '$(DIR)/$(1)/cl-$(2)/{pass}.exr' \
	  --stats $(DIR)/$(1)/cl-$(2).json $(T) 2>&1 | tail -1
	$(LOAD) $(DIR)/$(1)/cl-$(2).load
	$(COLLECT) --record $(DIR)/$(1)/cl-$(2).json --method cl-$(2) --label cl-$(2) --alpha 0.7 \
	  $$(RUNARGS_$(1)) --load $(DIR)/$(1)/cl-$(2).load -o $$@
TSVS += $(DIR)/$(1)/cl-$(2).tsv
endef

$(foreach s,$(SCENES),$(eval $(call SCENE_RULES,$(s))))
$(foreach s,$(SCENES),$(eval $(call PPM_RULE,$(s),ppm,0.7,$(EYE_SPP_$(s)))))
$(foreach s,$(SCENES),$(foreach a,$(ALPHAS),$(eval $(call PPM_RULE,$(s),ppm-a$(a),$(a),$(SWEEP_EYE_SPP)))))
$(foreach s,$(SCENES),$(foreach m,$(CL_METHODS),$(eval $(call CL_RULE,$(s),$(m)))))
$(foreach s,$(SCENES),$(foreach e,$(ESTIMATORS),$(eval $(call EST_RULE,$(s),$(e)))))

# The PPM reference recipe on the diffuse box, against its path-traced reference.
REFCHECK := $(DIR)/cornell-box/refcheck.tsv
$(REFCHECK): $(DIR)/cornell-box/scene.h5 $(DIR)/cornell-box/ref.exr $(DIR)/cornell-box/mask.exr \
    $(call param_stamp,$(DIR)/cornell-box/.refcheck,$(REF_SEED) $(REF_PHOTONS) $(REF_PASSES) $(REF_EYE_SPP))
	@rm -rf $(DIR)/cornell-box/refcheck && mkdir -p $(DIR)/cornell-box/refcheck
	$(LOAD) $(DIR)/cornell-box/refcheck.load
	$(BIN)/render --scene $< -o $(DIR)/cornell-box/refcheck/final.exr --estimator ppm --direct photons --passes $(REF_PASSES) \
	  --photons $(REF_PHOTONS) --spp $(REF_EYE_SPP) --seed $(REF_SEED) \
	  --snapshot-at $(call snaps,$(REF_PASSES)) --snapshot '$(DIR)/cornell-box/refcheck/{pass}.exr' \
	  --stats $(DIR)/cornell-box/refcheck.json $(TR) | tail -1
	$(LOAD) $(DIR)/cornell-box/refcheck.load
	$(COLLECT) --record $(DIR)/cornell-box/refcheck.json --method ppm-ref --label ppm-ref \
	  --alpha 0.7 $(RUNARGS_cornell-box) --load $(DIR)/cornell-box/refcheck.load -o $@
refcheck: $(REFCHECK)
ifneq ($(filter cornell-box,$(SCENES)),)
TSVS += $(REFCHECK)
endif

runs: $(TSVS)

# Charts and the generated tables (docs/results/accuracy.md); RESULTS.md discusses them.
REPORT := $(RES)/accuracy.md
report: $(REPORT)
$(REPORT): $(TSVS) bench/accuracy.py
	@mkdir -p $(RES)
	$(PY) bench/accuracy.py report --dir $(DIR) --res $(RES) --scenes "$(SCENES)" \
	  --alphas "$(ALPHAS)" --settings "W=$(W) H=$(H) PT_SPP=$(PT_SPP) PHOTONS=$(PHOTONS) \
	  PASSES=$(PASSES) $(foreach s,$(SCENES),EYE_SPP_$(s)=$(EYE_SPP_$(s))) \
	  SWEEP_EYE_SPP=$(SWEEP_EYE_SPP) CL_PASSES=$(CL_PASSES) REF_SPP=$(REF_SPP) MASK_SPP=$(MASK_SPP) \
	  REF_PHOTONS=$(REF_PHOTONS) REF_PASSES=$(REF_PASSES) REF_EYE_SPP=$(REF_EYE_SPP) \
	  SEED=$(SEED) REF_SEED=$(REF_SEED) THREADS=$(THREADS) REF_THREADS=$(REF_THREADS) \
	  ESTIMATORS=$(ESTIMATORS)"
