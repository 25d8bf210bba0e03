# pfm-mpm: the two commands a newcomer needs are `make run` and `make test` (see README.md).
# Python runs as the Debian interpreter (the first python on PATH may be another that cannot see
# the Debian packages); its modules come as Debian packages (DEB_PYTHON_MODULES).
PYTHON ?= /usr/bin/python3
BUILD_DIR ?= build
SANITIZE_DIR ?= build-sanitize
JOBS ?= 2
CASE ?= cases/bearing_quasi_static.json
OUT ?= results/bearing_quasi_static

# Debian packages the build, the tests and the studies need. Debian names the package of a Python
# module after the interpreter's file name without its minor version, followed by a dash and the
# module (DEB_PYTHON_PREFIX, from $(PYTHON)); Python itself always runs as $(PYTHON).
DEB_PYTHON_PREFIX := $(basename $(notdir $(PYTHON)))-
DEB_PYTHON_MODULES := numpy scipy matplotlib pandas skimage pytest pytest-xdist jinja2 tqdm tabulate h5py \
  meshio gmsh dolfinx distributed docutils
# libopenblas0-serial: the BLAS under UMFPACK (the implicit solver's factorisation); Debian's
# alternatives take it over the reference BLAS once installed. Serial: one thread, the same bytes
# from run to run.
DEB_PACKAGES := cmake make g++ git clang-format black \
  libeigen3-dev libsuitesparse-dev libopenblas0-serial nlohmann-json3-dev libcli11-dev libhdf5-dev zlib1g-dev \
  libgtest-dev libgmock-dev libbenchmark-dev libgmsh-dev gmsh pybind11-dev $(DEB_PYTHON_PREFIX)dev \
  $(addprefix $(DEB_PYTHON_PREFIX),$(DEB_PYTHON_MODULES))

.PHONY: help deps build run test format-check test-cpp test-python test-studies sanitize bench format clean study \
  report study-boundary study-quadrature study-timing study-parametric study-convergence \
  study-benchmarks study-stability study-near_boundary study-implicit
.DEFAULT_GOAL := help

help:
	@echo "pfm-mpm: make TARGET (README.md)"
	@echo "  run           build, run the default case ($(CASE)) and its comparison page into $(OUT)"
	@echo "  test          build and run every test: C++ (also under ASan + UBSan), Python, quick studies"
	@echo "  build         install missing Debian packages (deps) and build into $(BUILD_DIR)"
	@echo "  deps          install the Debian packages the build, tests and studies need"
	@echo "  bench         the benchmarks (pfm-bench, pfm-bench-detect)"
	@echo "  study         every study; study-NAME one of boundary quadrature timing parametric"
	@echo "                convergence benchmarks stability near_boundary implicit (QUICK=1 quick variants,"
	@echo "                SCHEDULER=tcp://... Dask)"
	@echo "  report        the nightly accuracy report from the studies"
	@echo "  fuzz          libFuzzer on the input readers and the detector (clang)"
	@echo "  format        clang-format and black over the tracked sources (format-check: check only)"
	@echo "  clean         remove $(BUILD_DIR) and $(SANITIZE_DIR)"

SCHEDULER ?=
STUDY_FLAGS = $(if $(SCHEDULER),--scheduler $(SCHEDULER),) $(if $(QUICK),--quick,)

deps:
	@missing=""; for p in $(DEB_PACKAGES); do \
	  dpkg-query -W -f='$${Status}' $$p 2>/dev/null | grep -q 'ok installed' || missing="$$missing $$p"; \
	done; \
	if [ -n "$$missing" ]; then \
	  if [ "$$(id -u)" = 0 ]; then \
	    echo "make deps: installing$$missing"; \
	    apt-get update -q && DEBIAN_FRONTEND=noninteractive apt-get install -y -q $$missing; \
	  else \
	    echo "make deps: missing Debian packages; run as root:"; \
	    echo "  apt-get install$$missing"; exit 1; \
	  fi; \
	fi

build: deps
	@cmake -S . -B $(BUILD_DIR) -DCMAKE_BUILD_TYPE=Release > /dev/null
	@cmake --build $(BUILD_DIR) -j $(JOBS)

# The default case (a quasi-static strip load on the detected boundary) with the MPM, the UL-FEM
# and the static dolfinx model: OUT/mpm, OUT/ulfem, OUT/dolfinx (the runs), OUT/index.html and
# OUT/report.md (what is compared, the verdict, the figures); see studies/demo.py.
run: build
	PFM_BUILD_DIR=$(abspath $(BUILD_DIR)) $(PYTHON) -m studies demo --case $(CASE) --out $(OUT)

test: build format-check test-cpp test-python test-studies test-sanitize

# `make format` leaves the committed tree as it is: checked by `make test`.
format-check:
	@git ls-files '*.cpp' '*.hpp' | xargs clang-format --dry-run --Werror
	@git ls-files '*.py' | xargs black -q --check

test-cpp:
	cd $(BUILD_DIR) && ctest --output-on-failure -j $(JOBS) --timeout 600

# pytest exits 5 when it collects nothing; that is not a failure of the suite. The tests run on
# JOBS workers (pytest-xdist), each test on one: most of them wait on a pfm-mpm run.
test-python:
	PFM_BUILD_DIR=$(abspath $(BUILD_DIR)) $(PYTHON) -m pytest -q -p no:cacheprovider -n $(JOBS) --dist load tests/python $(wildcard fem_reference/tests) $(wildcard studies/tests) $(wildcard studies/detectors/tests); \
	  rc=$$?; if [ $$rc -eq 5 ]; then echo "no Python tests collected"; exit 0; fi; exit $$rc

sanitize: deps
	@cmake -S . -B $(SANITIZE_DIR) -DCMAKE_BUILD_TYPE=Sanitize -DPFM_BENCHMARKS=OFF -DPFM_PYTHON=OFF > /dev/null
	@cmake --build $(SANITIZE_DIR) -j $(JOBS)
	cd $(SANITIZE_DIR) && ASAN_OPTIONS=detect_leaks=1 UBSAN_OPTIONS=print_stacktrace=1 \
	  LSAN_OPTIONS=suppressions=$(abspath tests/lsan_suppressions.txt) \
	  ctest --output-on-failure -j $(JOBS) --timeout 900

# Reliability (issue 7): `make test` also runs the C++ tests under ASan + UBSan, and `make fuzz`
# runs libFuzzer on the input readers and the detector for FUZZ_SECONDS each (clang;
# tests/fuzz/README.md).
.PHONY: test-sanitize fuzz
FUZZ_DIR ?= build-fuzz
FUZZ_SECONDS ?= 600
test-sanitize: sanitize

fuzz: deps
	@$(MAKE) --no-print-directory deps DEB_PACKAGES="clang libclang-rt-dev libomp-dev"
	@CC=clang CXX=clang++ cmake -S . -B $(FUZZ_DIR) -DCMAKE_BUILD_TYPE=RelWithDebInfo -DPFM_FUZZ=ON > /dev/null
	@cmake --build $(FUZZ_DIR) -j $(JOBS) --target fuzz_case fuzz_particle_csv fuzz_config fuzz_detect
	PYTHON=$(PYTHON) tests/fuzz/run_fuzz.sh $(FUZZ_DIR) $(FUZZ_SECONDS)

bench: build
	$(BUILD_DIR)/bin/pfm-bench
	$(BUILD_DIR)/bin/pfm-bench-detect

# Studies (studies/): `make study-NAME`, `make study` for all, `make report` for the nightly
# accuracy report. QUICK=1 runs the quick variants; SCHEDULER=tcp://host:8786 uses Dask.
study-boundary study-quadrature study-timing study-parametric study-convergence study-benchmarks \
  study-stability study-near_boundary study-implicit: build
	PFM_BUILD_DIR=$(abspath $(BUILD_DIR)) $(PYTHON) -m studies $(@:study-%=%) $(STUDY_FLAGS)

study: build
	PFM_BUILD_DIR=$(abspath $(BUILD_DIR)) $(PYTHON) -m studies all $(STUDY_FLAGS)

report:
	PFM_BUILD_DIR=$(abspath $(BUILD_DIR)) $(PYTHON) -m studies report

# The quick variant of every study (about 1.5 min) into the build folder, and its report with
# the thresholds shown but not gating (`make report` gates the full studies).
test-studies: build
	PFM_BUILD_DIR=$(abspath $(BUILD_DIR)) PFM_RESULTS=$(abspath $(BUILD_DIR))/studies-quick \
	  $(PYTHON) -m studies all --quick
	PFM_BUILD_DIR=$(abspath $(BUILD_DIR)) PFM_RESULTS=$(abspath $(BUILD_DIR))/studies-quick \
	  $(PYTHON) -m studies report --no-history --warn-only

format:
	git ls-files '*.cpp' '*.hpp' | xargs clang-format -i
	@command -v black > /dev/null && git ls-files '*.py' | xargs black -q || echo "black not installed: Python left as is"

clean:
	rm -rf $(BUILD_DIR) $(SANITIZE_DIR)
