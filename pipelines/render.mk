# render.mk — the default render's stage DAG, intermediates under $(OUT)/$(SCENE)/.
#
# Until the render stages land (issue 3), the DAG is one stage: scene-bake. Running it again with
# the same inputs and parameters does nothing; changing a parameter reruns only what depends on it.
#
# Variables: BIN (folder of the stage executables), SCENE (name of a scene in data/),
# OUT (output root), BAKE_FLAGS (extra scene-bake options, e.g. --width 320 --height 280).
BIN        ?= build/bin
SCENE      ?= cornell-box
OUT        ?= out
BAKE_FLAGS ?=
SCENE_FILE ?= $(firstword $(wildcard data/$(SCENE).dae data/$(SCENE).obj data/$(SCENE).gltf \
                                     data/$(SCENE).glb data/$(SCENE).ply))
DIR := $(OUT)/$(SCENE)

include pipelines/stamp.mk

ifeq ($(SCENE_FILE),)
$(error no scene named '$(SCENE)' in data/ (looked for .dae .obj .gltf .glb .ply))
endif

.PHONY: render
render: $(DIR)/scene.h5
	@echo "render: $(DIR)/scene.h5 is up to date (the render stages come with issue 3)"

$(DIR)/scene.h5: $(SCENE_FILE) $(BIN)/scene-bake $(call param_stamp,$(DIR)/bake.params,$(BAKE_FLAGS))
	$(BIN)/scene-bake $(SCENE_FILE) -o $@ $(BAKE_FLAGS)
