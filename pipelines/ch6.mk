# ch6.mk — the thesis's ch. 6.5 experiments on this machine: spatial index
# (Table 6.1), photon-map build and k-nearest search with ANN, FLANN and nanoflann (Tables
# 6.2–6.5), image error of approximate search (Fig. 6.8). Tables go to docs/results/ch6-*.md,
# charts to docs/results/ch6-*.png; docs/results/ch6.md discusses them (written by hand).
#
#   make -f pipelines/ch6.mk                  everything (about 10 minutes on 2 cores)
#   make -f pipelines/ch6.mk index            Table 6.1 only
#   make -f pipelines/ch6.mk BUILD=build-ch6 RUNS=5
#
# The benchmarks are built first (cmake --build, in an already configured BUILD); a table is
# measured again when its benchmark binary changed. Intermediates (the tab-separated tables, the
# images per ε) go to $(OUT)/ch6/. Meshes from ../shared/scenes are used when present (the
# benchmark says when it had to use a procedural stand-in).
BUILD  ?= build
BIN    ?= $(BUILD)/bin
OUT    ?= out
RES    ?= docs/results
RUNS   ?= 3
MESHES ?= ../shared/scenes/teapot.obj,../shared/scenes/spot.obj
DIR    := $(OUT)/ch6
CHARTS := $(addprefix $(RES)/ch6-,build.png knn-k.png knn-size.png eps.png fig6.8.png)

.PHONY: all index photonmap FORCE
all: index photonmap
index: $(RES)/ch6-index.md
photonmap: $(RES)/ch6-photonmap.md $(CHARTS)

$(DIR) $(RES):
	@mkdir -p $@

# cmake decides whether a binary is out of date; its timestamp changes only when it was rebuilt.
$(BIN)/bench_ch6_%: FORCE
	@cmake --build $(BUILD) --target bench_ch6_$* > /dev/null

$(RES)/ch6-index.md: $(BIN)/bench_ch6_index | $(RES)
	$(BIN)/bench_ch6_index --runs $(RUNS) --meshes $(MESHES) > $@.tmp
	@mv $@.tmp $@

# One run writes the table and, as a side product, the chart data and images in $(DIR).
$(RES)/ch6-photonmap.md $(DIR)/ch6-knn-eps.dat &: $(BIN)/bench_ch6_photonmap | $(RES) $(DIR)
	$(BIN)/bench_ch6_photonmap --runs $(RUNS) --dat $(DIR) --image-dir $(DIR) \
	  > $(RES)/ch6-photonmap.md.tmp
	@mv $(RES)/ch6-photonmap.md.tmp $(RES)/ch6-photonmap.md

$(CHARTS) &: $(DIR)/ch6-knn-eps.dat bench/ch6.gp bench/ch6_thesis.dat | $(RES)
	gnuplot -e "dat='$(DIR)'; res='$(RES)'; thesis='bench/ch6_thesis.dat'" bench/ch6.gp
