# scene.mk — which scene file SCENE names, and the folder name of its intermediates; included by
# the top-level Makefile and pipelines/render.mk, so both agree.
#
# SCENE is either a path to a scene file (any format scene-bake reads: .dae, .obj, .gltf, .glb,
# .ply, ...; relative to the repository root or absolute) or the name of one in data/
# (cornell-box = data/cornell-box.dae). SCENE_NAME is the file's stem for a path
# (SCENE=~/models/ship.glb → ship) and the name itself for data/, so intermediates go under
# $(OUT)/$(SCENE_NAME)/. (Make cannot take a path with spaces.)
SCENE_IS_PATH := $(shell test -f '$(SCENE)' && echo yes)
SCENE_FILE ?= $(if $(SCENE_IS_PATH),$(SCENE),$(firstword $(wildcard data/$(SCENE).dae \
  data/$(SCENE).obj data/$(SCENE).gltf data/$(SCENE).glb data/$(SCENE).ply)))
SCENE_NAME ?= $(if $(SCENE_IS_PATH),$(basename $(notdir $(SCENE))),$(SCENE))

# Per-scene scene-bake options: a text file NAME.bake-options beside the scene file (for
# data/showcase.gltf: data/showcase.bake-options) holds options that the file format cannot carry,
# e.g. depth of field (--aperture, --focus-distance: glTF and assimp cameras have no aperture).
# '#' starts a comment; the rest is passed to scene-bake before BAKE_FLAGS, so BAKE_FLAGS wins
# for an option given in both (scene-bake takes the last). SCENE_BAKE_OPTIONS= (empty) ignores
# the file.
SCENE_OPTIONS_FILE := $(if $(SCENE_FILE),$(basename $(SCENE_FILE)).bake-options)
SCENE_BAKE_OPTIONS ?= $(if $(wildcard $(SCENE_OPTIONS_FILE)),$(strip $(shell sed -e 's/\#.*//' '$(SCENE_OPTIONS_FILE)')))
