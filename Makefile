# dygslam: one-command setup, build, demo and tests.
#   make demo    set up, build, get the demo data, run SLAM on Bonn `crowd` (excerpt), evaluate
#   make test    set up, build, run the whole test suite
#   make build   configure + build only
# Variables: BUILD_DIR (build), JOBS (2), CMAKE_ARGS (extra cmake options, e.g.
# -DDYGSLAM_BUILD_DDS=OFF), DEMO_OUT (out/demo), DYGSLAM_DATA_DIR (where datasets are looked up).

SHELL := /bin/bash

BUILD_DIR ?= build
JOBS ?= 2
CMAKE_ARGS ?=
DEMO_OUT ?= out/demo
DYGSLAM := $(BUILD_DIR)/apps/dygslam

.PHONY: all setup configure build test demo clean help

all: build

help:
	@sed -n '2,6p' Makefile | sed 's/^# \{0,1\}//'

setup:
	scripts/setup.sh

configure: setup
	cmake -S . -B $(BUILD_DIR) -DCMAKE_BUILD_TYPE=Release $(CMAKE_ARGS)

build: configure
	cmake --build $(BUILD_DIR) -j$(JOBS)

test: build
	ctest --test-dir $(BUILD_DIR) --output-on-failure -j$(JOBS)

demo: build
	@set -eo pipefail; \
	data=$$(scripts/fetch_data.sh bonn_crowd_part); \
	echo "demo: dataset $$data"; \
	mkdir -p $(DEMO_OUT); \
	$(DYGSLAM) run "$$data" --config config/bonn.yaml --filter full --out $(DEMO_OUT); \
	if [ -f "$$data/groundtruth.txt" ]; then \
	  $(DYGSLAM) eval "$$data/groundtruth.txt" $(DEMO_OUT)/trajectory.txt --plot $(DEMO_OUT)/ate.png \
	    | tee $(DEMO_OUT)/eval.txt; \
	  $(DYGSLAM) eval "$$data/groundtruth.txt" $(DEMO_OUT)/trajectory.txt --json > $(DEMO_OUT)/eval.json; \
	fi; \
	echo ""; \
	echo "demo: outputs in $(DEMO_OUT)/"; \
	ls -1 $(DEMO_OUT) | sed 's/^/  /'

clean:
	rm -rf $(BUILD_DIR)
