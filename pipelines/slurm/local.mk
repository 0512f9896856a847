# local.mk — a run of pipelines/slurm/ on one machine: the same tasks and merge as the Slurm job
# array and merge job, as a Make DAG (one target per part, the image after all parts), so that
# `make -j` runs the tasks side by side and a rerun renders only the parts that are missing.
#
#   pipelines/slurm/submit.sh --prepare-only --scene scene.h5 --out RUN [options]
#   make -j2 -f pipelines/slurm/local.mk RUN=RUN [THREADS=1]
#
# THREADS: render threads per task (default 1: make -j sets how many tasks run at once).
SHELL   := /bin/bash
RUN     ?=
THREADS ?= 1
ifeq ($(RUN),)
$(error RUN=folder is needed: a run prepared by pipelines/slurm/submit.sh --prepare-only)
endif
ifeq ($(wildcard $(RUN)/run.env),)
$(error $(RUN)/run.env: no such file (prepare the run with pipelines/slurm/submit.sh --prepare-only))
endif
# From here on, the run's absolute path (as the parts are named in run.env).
override RUN := $(shell . '$(RUN)/run.env' && echo "$$RUN")
PIPE  := $(shell . '$(RUN)/run.env' && echo "$$PIPE")
PPT   := $(shell . '$(RUN)/run.env' && echo "$$PPT")
# The parts, in task order (common.sh names them).
PARTS := $(shell . '$(RUN)/run.env' && . '$(PIPE)/common.sh' && \
           for ((k = 0; k < TASKS; ++k)); do pf_part $$k; echo; done)

.PHONY: all
all: $(RUN)/image.exr

# A part's task: its first pass (the name's first number) over the passes per task.
$(RUN)/parts/passes-%.h5:
	first=$(firstword $(subst -, ,$*)); \
	env -u SLURM_CPUS_PER_TASK SLURM_ARRAY_TASK_ID=$$((10#$$first / $(PPT))) THREADS=$(THREADS) \
	  '$(PIPE)/task.sh' '$(RUN)'

$(RUN)/image.exr: $(PARTS)
	'$(PIPE)/merge.sh' '$(RUN)'
