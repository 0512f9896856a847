# scene.mk — which scene file SCENE names, and the folder name of its intermediates; included by
# the top-level Makefile and pipelines/render.mk, so both agree.
#
# SCENE is either a path to a scene file (any format scene-bake reads: .dae, .obj, .gltf, .glb,
# .ply, ...; relative to the repository root or absolute) or the name of one in data/
# (cornell-box = data/cornell-box.dae). SCENE_NAME is the file's stem for a path
# (SCENE=~/models/ship.glb → ship) and the name itself for data/, so intermediates go under
# $(OUT)/$(SCENE_NAME)/.
#
# SCENE is checked first (pipelines/names.mk): only A-Z a-z 0-9 . _ / + ~ @ , - and no leading
# '-'; any other name (a space, a quote, ; $ ` or a newline in it) stops make with one line before
# anything runs, and such a scene renders with build/bin/render --scene FILE directly. Nothing
# below hands SCENE or a file's contents to a shell: the file tests are make's own $(wildcard).
include pipelines/names.mk
$(call pf_check_name,SCENE)
# A path to a file (not a directory: $(wildcard D/.) finds a directory D).
SCENE_IS_PATH := $(if $(wildcard $(SCENE)),$(if $(wildcard $(SCENE)/.),,yes))
SCENE_FILE ?= $(if $(SCENE_IS_PATH),$(SCENE),$(firstword $(wildcard data/$(SCENE).dae \
  data/$(SCENE).obj data/$(SCENE).gltf data/$(SCENE).glb data/$(SCENE).ply)))
SCENE_NAME ?= $(if $(SCENE_IS_PATH),$(basename $(notdir $(SCENE))),$(SCENE))

# Per-scene scene-bake options: a text file NAME.bake-options beside the scene file (for
# data/showcase.gltf: data/showcase.bake-options) holds options that the file format cannot carry,
# e.g. depth of field (--aperture, --focus-distance: glTF and assimp cameras have no aperture).
# scene-bake reads the file itself (--options-file: words, '#' comments, no shell; docs/SCENES.md),
# and the command line's options (WIDTH, HEIGHT, BAKE_FLAGS) come after the file's, so they win
# for an option given in both. SCENE_BAKE_OPTIONS names the file: by default NAME.bake-options
# when it exists; SCENE_BAKE_OPTIONS= (empty) reads none (scene-bake --no-options-file). It is a
# prerequisite of the bake, so editing it bakes again.
SCENE_OPTIONS_FILE := $(if $(SCENE_FILE),$(basename $(SCENE_FILE)).bake-options)
ifeq ($(origin SCENE_BAKE_OPTIONS),undefined)
SCENE_BAKE_OPTIONS := $(wildcard $(SCENE_OPTIONS_FILE))
else ifneq ($(value SCENE_BAKE_OPTIONS),)
$(call pf_check_name,SCENE_BAKE_OPTIONS)
endif
SCENE_OPTIONS_ARG = $(if $(SCENE_BAKE_OPTIONS),--options-file $(SCENE_BAKE_OPTIONS),--no-options-file)
