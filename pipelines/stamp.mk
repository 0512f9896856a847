# stamp.mk — parameter stamps for the stage DAG.
#
# $(call param_stamp,FILE,TEXT) rewrites FILE only when TEXT differs from its content. A stage
# that lists FILE as a prerequisite therefore reruns when (and only when) its parameters change,
# and make's timestamps carry that down the DAG to the stages after it.
# The stamp is written while the makefile is read, so `make -n` with other parameters also rewrites
# it; that can only cause a later rerun, never a stale result.
define param_stamp
$(shell mkdir -p $(dir $(1)) && (printf '%s\n' '$(2)' | cmp -s - $(1) 2>/dev/null || printf '%s\n' '$(2)' > $(1)))$(1)
endef
