# SVMS quick start: `make demo` and `make test` (each runs scripts/bootstrap first, which
# installs any missing Debian package and does nothing when all are present).
BUILD ?= build
JOBS ?= $(shell nproc 2>/dev/null || echo 2)
CMAKE_FLAGS ?=

.PHONY: all deps configure build test demo bench clean

all: build

deps:
	@scripts/bootstrap

$(BUILD)/CMakeCache.txt: | deps
	cmake -S . -B $(BUILD) $(CMAKE_FLAGS)

configure: deps $(BUILD)/CMakeCache.txt

build: configure
	cmake --build $(BUILD) -j $(JOBS)

test: build
	ctest --test-dir $(BUILD) --output-on-failure -j $(JOBS)

demo: build
	scripts/demo $(BUILD)/bin/svms out/demo

bench: build
	scripts/update_benchmarks $(BUILD)

clean:
	rm -rf $(BUILD) out
