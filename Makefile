# dygslam: one-command setup, build, demo and tests.
#   make demo    set up, build, get the demo data, run SLAM on Bonn `crowd` (excerpt), evaluate
#   make test    set up, build, run the whole test suite
#   make build   configure + build only
#   make test-asan  build the test suite with ASan/UBSan in $(ASAN_BUILD_DIR) and run it
# Variables: BUILD_DIR (build), JOBS (2), CMAKE_ARGS (extra cmake options, e.g.
# -DDYGSLAM_BUILD_DDS=OFF), DEMO_OUT (out/demo), DYGSLAM_DATA_DIR (where datasets are looked up).

SHELL := /bin/bash

BUILD_DIR ?= build
JOBS ?= 2
CMAKE_ARGS ?=
DEMO_OUT ?= out/demo
DYGSLAM := $(BUILD_DIR)/apps/dygslam
ASAN_BUILD_DIR ?= build-asan
ASAN_CTEST_ARGS ?=
# Multi-process DDS tests share 2 cores with everything else; one retry keeps a timing hiccup from
# failing the suite (a real failure fails twice). Set CTEST_ARGS= to run each test once.
CTEST_ARGS ?= --repeat until-pass:2

.PHONY: all setup configure build test test-asan demo clean help

all: build

help:
	@sed -n '2,7p' Makefile | sed 's/^# \{0,1\}//'

setup:
	scripts/setup.sh

configure: setup
	cmake -S . -B $(BUILD_DIR) -DCMAKE_BUILD_TYPE=Release $(CMAKE_ARGS)

build: configure
	cmake --build $(BUILD_DIR) -j$(JOBS)

test: build
	ctest --test-dir $(BUILD_DIR) --output-on-failure -j$(JOBS) $(CTEST_ARGS)

# Sanitizer CI option: the whole suite under AddressSanitizer + UndefinedBehaviorSanitizer (any
# report fails the test). Slow (~2-3x); ASAN_CTEST_ARGS narrows it, e.g. ASAN_CTEST_ARGS='-R ^reliability/'.
test-asan: setup
	cmake -S . -B $(ASAN_BUILD_DIR) -DCMAKE_BUILD_TYPE=RelWithDebInfo -DDYGSLAM_SANITIZE=ON $(CMAKE_ARGS)
	cmake --build $(ASAN_BUILD_DIR) -j$(JOBS)
	ASAN_OPTIONS=detect_leaks=1:abort_on_error=1:detect_stack_use_after_return=0 \
	UBSAN_OPTIONS=halt_on_error=1:print_stacktrace=1 \
	ctest --test-dir $(ASAN_BUILD_DIR) --output-on-failure -j$(JOBS) --timeout 1800 $(ASAN_CTEST_ARGS)

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
