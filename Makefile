# SVMS quick start: `make demo` and `make test` (each runs scripts/bootstrap first, which
# installs any missing Debian package and does nothing when all are present).
BUILD ?= build
JOBS ?= $(shell nproc 2>/dev/null || echo 2)
CMAKE_FLAGS ?=

.PHONY: all deps configure build test demo bench clean sanitize-build test-asan fuzz test-sanitize

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

# Hardening (docs/reliability.md), all in ONE clang build directory, SANITIZE_BUILD: the library
# with AddressSanitizer + UndefinedBehaviorSanitizer and libFuzzer's coverage, the gtest
# executables with ASan + UBSan, the fuzz targets with libFuzzer.
#   make test-sanitize  what .ci/run runs after `make test`: test-asan, then fuzz
#   make test-asan      the unit tests (ctest label "unit") under ASan + UBSan. The exhaustive
#                       sweep of every ID with two flipped bits (pure integer decoding, ~5 min
#                       per rotation under ASan) and the rendered NEES statistics (48 and 12
#                       renders, 96 and 212 s under ASan; the same code paths as the faster
#                       rendered tests) and the corners' joint covariance against 150 noisy
#                       synthetic squares (the code paths of the other RefineCorners tests) and
#                       the rendered two-camera rig (RigPoseEstimator's paths, which
#                       CapiRig.ProcessRigFrameIsTheRigPoseEstimators runs under ASan too) and
#                       the rig survey's Monte Carlo runs (300 solves; the paths of
#                       SurveyRig.RecoversTheExtrinsicsWithinTheirCovariance) and the threads'
#                       16-marker bit-for-bit render and the timed edge-map deadline on 1024 x
#                       1024 texture (threads under ASan: WorkerPool, EdgeBands and the dual
#                       marker's 2-thread comparison) run only in `make test`.
#   make fuzz           each libFuzzer target of fuzz/ for FUZZ_SECONDS from its seeds
# Stack traces need file and line only: line tables instead of full debug info (of Eigen, Ceres
# and OpenCV templates) keep the build shorter.
SANITIZE_BUILD ?= build-sanitize
FUZZ_SECONDS ?= 15
SANITIZE_ENV = LSAN_OPTIONS=suppressions=$(CURDIR)/cmake/lsan.supp UBSAN_OPTIONS=print_stacktrace=1
SANITIZE_UNIT = $(SANITIZE_ENV) ctest --test-dir $(SANITIZE_BUILD) -L unit -E "EveryIdTwoFlips|NeesIsNearSix|TheCornersJointCovariance|RenderedTwoCameraRig|SeveralThreadsGiveTheSameDetectionsToTheBit|ADeadlinePassedBeforeTheEdgeMapEnds|SurveyRig.*MonteCarlo|ALoneDistantMarkersFusedPose" \
  --output-on-failure -j $(JOBS)
SANITIZE_FUZZ = $(SANITIZE_ENV) scripts/run_fuzz $(SANITIZE_BUILD) $(FUZZ_SECONDS)

sanitize-build: deps
	cmake -S . -B $(SANITIZE_BUILD) -DCMAKE_C_COMPILER=clang -DCMAKE_CXX_COMPILER=clang++ \
	  -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O2 -gline-tables-only -DNDEBUG" \
	  -DCMAKE_C_FLAGS_RELWITHDEBINFO="-O2 -gline-tables-only -DNDEBUG" \
	  -DSVMS_SANITIZE=ON -DSVMS_FUZZ=ON -DSVMS_BUILD_BENCHMARKS=OFF $(CMAKE_FLAGS)
	cmake --build $(SANITIZE_BUILD) -j $(JOBS) --target unit_tests fuzz_targets

test-asan: sanitize-build
	$(SANITIZE_UNIT)

fuzz: sanitize-build
	$(SANITIZE_FUZZ)

# One after the other (also under make -j), the unit tests first.
test-sanitize: sanitize-build
	$(SANITIZE_UNIT)
	$(SANITIZE_FUZZ)

demo: build
	scripts/demo $(BUILD)/bin/svms out/demo

bench: build
	scripts/update_benchmarks $(BUILD)

clean:
	rm -rf $(BUILD) $(SANITIZE_BUILD) out
