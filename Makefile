# SVMS quick start: `make demo` and `make test` (each runs scripts/bootstrap first, which
# installs any missing Debian package and does nothing when all are present).
BUILD ?= build
JOBS ?= $(shell nproc 2>/dev/null || echo 2)
CMAKE_FLAGS ?=

.PHONY: all deps configure build test demo bench clean test-asan fuzz

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

# The unit tests (ctest label "unit") under AddressSanitizer + UndefinedBehaviorSanitizer, in
# their own build directory; docs/reliability.md. The exhaustive sweep of every ID with two
# flipped bits (pure integer decoding, ~5 min per rotation under ASan) runs only in `make test`.
ASAN_BUILD ?= build-asan
test-asan: deps
	cmake -S . -B $(ASAN_BUILD) -DSVMS_SANITIZE=ON -DSVMS_BUILD_BENCHMARKS=OFF $(CMAKE_FLAGS)
	cmake --build $(ASAN_BUILD) -j $(JOBS) --target unit_tests
	LSAN_OPTIONS=suppressions=$(CURDIR)/cmake/lsan.supp UBSAN_OPTIONS=print_stacktrace=1 \
	  ctest --test-dir $(ASAN_BUILD) -L unit -E EveryIdTwoFlips --output-on-failure -j $(JOBS)

# The libFuzzer targets (clang) built in FUZZ_BUILD, each run FUZZ_SECONDS from its seeds.
FUZZ_BUILD ?= build-fuzz
FUZZ_SECONDS ?= 10
fuzz: deps
	cmake -S . -B $(FUZZ_BUILD) -DCMAKE_C_COMPILER=clang -DCMAKE_CXX_COMPILER=clang++ \
	  -DSVMS_FUZZ=ON -DSVMS_BUILD_TESTS=OFF -DSVMS_BUILD_BENCHMARKS=OFF
	cmake --build $(FUZZ_BUILD) -j $(JOBS) --target fuzz_targets
	scripts/run_fuzz $(FUZZ_BUILD) $(FUZZ_SECONDS)

demo: build
	scripts/demo $(BUILD)/bin/svms out/demo

bench: build
	scripts/update_benchmarks $(BUILD)

clean:
	rm -rf $(BUILD) $(ASAN_BUILD) $(FUZZ_BUILD) out
