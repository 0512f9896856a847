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
