# stamp.mk — parameter stamps for the stage DAG.
#
# $(call param_stamp,FILE,TEXT) rewrites FILE only when TEXT differs from its content. A stage
# that lists FILE as a prerequisite therefore reruns when (and only when) its parameters change,
# and make's timestamps carry that down the DAG to the stages after it.
define param_stamp
$(shell mkdir -p $(dir $(1)) && (printf '%s\n' '$(2)' | cmp -s - $(1) 2>/dev/null || printf '%s\n' '$(2)' > $(1)))$(1)
endef
