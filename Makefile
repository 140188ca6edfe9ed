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

# Hardening (docs/reliability.md), all in ONE clang build directory, SANITIZE_BUILD: the
# libraries with AddressSanitizer + UndefinedBehaviorSanitizer (and libFuzzer's coverage on the
# modules the fuzz targets reach), the gtest executables with ASan + UBSan, the fuzz targets
# with libFuzzer.
#   make test-sanitize  what .ci/run runs after `make test`: test-asan, then fuzz
#   make test-asan      the unit tests (ctest label "unit") under ASan + UBSan, less those in
#                       SANITIZE_SKIP: each repeats, many times, code paths that faster tests run
#                       under ASan too, and costs from half a minute to about 5 min there (CI has 60
#                       min for all of .ci/run). They run in `make test`. Pure integer decoding:
#                       every ID with two flipped bits, samples of four flips, every five-flip
#                       pattern of the strong subset, the family's statistics (a million random
#                       words). Monte Carlo: the response estimate's shot-noise bias (16 rendered
#                       images of squares; the other EstimateGammaFromEdges tests run its path), the
#                       rendered NEES statistics (48 and 12 renders, and the approach's fused NEES
#                       against its measure), the corners' joint covariance (150 noisy squares), the
#                       small quad's sigmas (300), Student's widening (400), correlated edge points
#                       and JPEG blocks (120 squares each), the small blurred marker's inward bias,
#                       the survey's repeated corner error and calibration uncertainty (30 surveys
#                       each), the rig survey's Monte Carlo runs (300 solves), the lone distant
#                       marker's fused pose. Renders: the fine grid's reference (a camera 4 times
#                       finer cast whole; every render casts the fine grid), the two-camera rig
#                       (CapiRig.ProcessRigFrameIsTheRigPoseEstimators runs its paths under ASan),
#                       the shadow edge along a side (the sun sweep's views), the threads' 16-marker
#                       bit-for-bit render and the timed edge-map deadline on 1024 x 1024 texture
#                       (WorkerPool, EdgeBands and the dual marker's 2-thread comparison run under
#                       ASan). And two whose paths other tests run under ASan: the rendered
#                       approach's frames (PoseEstimator.TheLatencyOfARawFrame... and
#                       TwoLayoutsShare... fuse frames of the same approach), the small rendered
#                       survey (survey_test's surveys run the solver; the detector runs in its own
#                       tests).
#   make fuzz           each libFuzzer target of fuzz/ for FUZZ_SECONDS from its seeds
# Stack traces need file and line only: line tables instead of full debug info (of Eigen, Ceres
# and OpenCV templates) keep the build shorter.
SANITIZE_BUILD ?= build-sanitize
FUZZ_SECONDS ?= 15
SANITIZE_ENV = LSAN_OPTIONS=suppressions=$(CURDIR)/cmake/lsan.supp UBSAN_OPTIONS=print_stacktrace=1
SANITIZE_SKIP = EveryIdTwoFlips|SampleFourFlips|StrongSubsetCorrectsEveryFiveFlipPattern|NeesIsNearSix|FusedNeesStaysWithinAFactorOfTwo|RefineCorners\.TheCornersJointCovariance|ASmallQuadsCornerSigmasAreHonest|WidenedByStudentsFactor|CorrelatedEdgePointsWidenTheCornerSigmas|ErrorsSharedWithinCodecBlocks|InwardBiasIsInItsCornerSigmas|Survey\.RepeatedCornerErrorIsPropagated|Survey\.CalibrationUncertaintyIsPropagated|SurveyRig.*MonteCarlo|ALoneDistantMarkersFusedPose|RenderedTwoCameraRig|AShadowEdgeAlongASideDoesNotMoveIt|SeveralThreadsGiveTheSameDetectionsToTheBit|ADeadlinePassedBeforeTheEdgeMapEnds|RenderedApproachFramesMatchTheTruthWithinTheirSigmas|SurveyRendered\.SmallRenderedScene|CodecStats\.MeasuresTheFamily|ShotNoiseDoesNotBiasTheEstimate|TheFineGridIsRenderedWhereTheLightChangesWithinAPixel
SANITIZE_UNIT = $(SANITIZE_ENV) ctest --test-dir $(SANITIZE_BUILD) -L unit -E "$(SANITIZE_SKIP)" \
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
