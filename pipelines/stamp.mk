# stamp.mk — parameter stamps for the stage DAG.
#
# $(call param_stamp,FILE,TEXT) rewrites FILE only when TEXT differs from its content. A stage
# that lists FILE as a prerequisite therefore reruns when (and only when) its parameters change,
# and make's timestamps carry that down the DAG to the stages after it.
# The stamp is written while the makefile is read, so `make -n` with other parameters also rewrites
# it; that can only cause a later rerun, never a stale result.
# TEXT never reaches a shell: make's own $(file) reads and writes the stamp (TEXT and a newline),
# so a quote or `;` in a parameter is just text. Only the stamp's folder is made by a shell
# (mkdir -p), from the pipeline's OUT and a checked scene name (names.mk).
# pf_same: "y" when $(1) and $(2) are the same text (each holds the other, with guards for "").
pf_same = $(and $(findstring x$(1)x,x$(2)x),$(findstring x$(2)x,x$(1)x),y)
define param_stamp
$(if $(wildcard $(dir $(1))),,$(shell mkdir -p $(dir $(1))))$(if $(call pf_same,$(file <$(1)),$(2)),,$(file >$(1),$(2)))$(1)
endef
