# photonflow — top-level entry points.
#
#   make render   install missing Debian packages, build (Release), render the default scene
#   make test     install missing Debian packages, build (Release), run the test suite (ctest)
#   make bench    build and run the benchmarks (long; results go to docs/BENCHMARKS.md by hand)
#   make ch6      the thesis's ch. 6 experiments: tables and charts into docs/results/
#   make accuracy speed against accuracy: error vs time and passes, charts into docs/results/
#
# Variables: SCENE (a name in data/, default cornell-box), OUT (default out), BUILD (default build),
# JOBS (default: all cores).
BUILD ?= build
JOBS  ?= $(shell nproc)
SCENE ?= cornell-box
OUT   ?= out
BIN   := $(abspath $(BUILD))/bin

.PHONY: all deps configure build render test bench ch6 accuracy clean help
all: build

help:
	@sed -n '2,11p' Makefile | sed 's/^# \{0,1\}//'

deps:
	@tools/setup/install-deps.sh

configure: deps
	@mkdir -p $(BUILD)
	@cmake -S . -B $(BUILD) -DCMAKE_BUILD_TYPE=Release > $(BUILD)/configure.log 2>&1 \
	  || { cat $(BUILD)/configure.log; exit 1; }

build: configure
	@cmake --build $(BUILD) -j$(JOBS)

render: build
	@$(MAKE) --no-print-directory -f pipelines/render.mk BIN=$(BIN) SCENE=$(SCENE) OUT=$(OUT)

test: build
	@cd $(BUILD) && ctest --output-on-failure -j$(JOBS)

bench: build
	@$(MAKE) --no-print-directory -f pipelines/bench.mk BIN=$(BIN) OUT=$(OUT)

ch6: build
	@$(MAKE) --no-print-directory -f pipelines/ch6.mk BUILD=$(BUILD) OUT=$(OUT)

accuracy: build
	@$(MAKE) --no-print-directory -f pipelines/accuracy.mk BUILD=$(BUILD) OUT=$(OUT)

clean:
	rm -rf $(BUILD)
