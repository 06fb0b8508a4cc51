# Gimlet: the two commands.
#
#   make demo   install missing system packages, build and install the
#               library into _install/, build the C drivers against the
#               installed package, run the main job under `mpiexec -n 2`
#               (the paper's wedge nanoindentation of aluminium: 3 nested
#               levels, a rigid wedge pushed to 450 nm and withdrawn, contact
#               pressures solved with PETSc) and plot its results; writes
#               results/ (CSV, HDF5 + XDMF for ParaView, PNG plots)
#   make multiscale   the paper's 5-level multiscale indentation (issue 15);
#               make multiscale-levels: with 4, 5 and 6 levels
#   make pressure-demo   the paper's indentation of silicon by a surface
#               pressure (3 levels, 2000 steps), as before
#   make friction-study   the J2 wedge nanoindentation with Coulomb friction
#               mu = 0, 0.1, 0.2, 0.3 at the wedge: load, pile-up, residual
#               depth, hardness and modulus; results/friction_study.csv and
#               README.md's friction table (scripts/friction_study.py)
#   make friction-study-cone   the same for the axisymmetric 70.3 deg cone
#               (cone_indentation --friction mu on 3 levels, J2 aluminium to
#               300 nm and back): results/friction_study_cone.csv and
#               README.md's cone friction table (friction_study.py --scene cone)
#   make scratch   a J2 aluminium block scratched by a wedge with friction
#               (mu = 0.2; 3 levels along the track): force series, groove
#               profile, XDMF; results/scratch.{csv,png}
#   make cone   the Berkovich-equivalent (70.3 deg cone) nanoindentation,
#               axisymmetric: J2 aluminium to 300 nm on 4 levels and back;
#               Oliver-Pharr hardness and modulus against the inputs, true
#               contact area, pile-up; results/cone.{csv,json,png}, XDMF
#   make bench  the speed benchmark in one sitting (not part of make test):
#               the comparison scene and a 1M-particle block through the C API
#               (USL, MUSL; 1 and 2 ranks), the 3-level pressure indentation
#               against its uniform-finest twin, the contact scene (a short
#               wedge push), the kernel-only reference line and, when their
#               runner is found (PEERS below), the peer codes; medians of 3
#               runs, writes results/bench.json and regenerates the speed
#               table of docs/performance.md from it (scripts/bench.py,
#               scripts/bench_docs.py)
#   make io-check   the MPI check of the io layer (gimlet-io-check of
#               crates/gimlet-validate) on 1 and 2 ranks
#   make test   everything CI checks: rustfmt, cargo tests (release), CMake
#               build + install into _install/, clippy, ctest; prints each
#               stage's wall and CPU time
#
# Variables: BUILD (CMake build dir), PREFIX (install prefix), JOBS,
# CARGO_TARGET_DIR (shared by cargo test, clippy, the CMake build and the
# benchmark; all build the library with the same flags and features, so
# it compiles once for all of them, in any order).

SHELL := /bin/bash

BUILD  ?= build
PREFIX ?= $(CURDIR)/_install
JOBS   ?= 2
NP     ?= 2
CARGO_TARGET_DIR ?= $(CURDIR)/$(BUILD)/cargo
export CARGO_TARGET_DIR

# Every recipe line sources the environment (Open MPI as root, HDF5_DIR).
ENV := source scripts/env.sh &&
CMAKE_ARGS := -DCMAKE_BUILD_TYPE=Release -DCMAKE_INSTALL_PREFIX=$(PREFIX) \
              -DGIMLET_CARGO_TARGET_DIR=$(CARGO_TARGET_DIR)

# $(call stage,NAME,COMMAND): run COMMAND in the environment and print its
# wall time and the CPU time (user + system) of everything it ran; the line
# fails when COMMAND fails. No commas inside COMMAND.
stage = @echo "=== $(1)"; set -o pipefail; \
        TIMEFORMAT="=== $(1): %1R s wall, %1U s user + %1S s system CPU"; \
        time { $(ENV) $(2); }; rc=$$?; [ $$rc -eq 0 ] || echo "=== $(1): FAILED (exit $$rc)"; exit $$rc

.PHONY: all setup configure build install examples demo bench io-check wedge-study friction-study friction-study-cone scratch cone multiscale multiscale-levels pressure-demo test test-stages clean

all: build

setup:
	@bash scripts/setup.sh

configure: setup
	$(ENV) cmake -S . -B $(BUILD) $(CMAKE_ARGS)

build: configure
	$(ENV) cmake --build $(BUILD) -j $(JOBS)

install: build
	$(ENV) cmake --install $(BUILD) --prefix $(PREFIX)

examples: install
	$(ENV) cmake -S examples-c -B $(BUILD)/examples-c \
	  -DCMAKE_BUILD_TYPE=Release -DCMAKE_PREFIX_PATH=$(PREFIX)
	$(ENV) cmake --build $(BUILD)/examples-c -j $(JOBS)
	mkdir -p results

demo: examples
	@t0=$$(date +%s); $(ENV) mpiexec -n $(NP) $(BUILD)/examples-c/wedge_indentation --petsc --out results && \
	/usr/bin/python3 scripts/plot_nanoindentation.py results && \
	echo "=== make demo: the run and its plots took $$(( $$(date +%s) - t0 )) s; results in $(CURDIR)/results: nanoindentation.csv (depth_m, load_n_per_m), nanoindentation_tip.csv, nanoindentation.xdmf + nanoindentation_*.h5 (open the .xdmf in ParaView), nanoindentation.png"

# The benchmark: builds the C drivers and the kernel-only gimlet-bench, runs
# scripts/bench.py (prints the table, our rate over each peer's and the
# targets; writes results/bench.json), then rewrites the speed table of
# docs/performance.md from that file.
# PEERS: the peer codes' runner (Warp, Taichi on the comparison scene). By
# default the one in the sandbox this project is developed in, beside the
# main checkout, when it is there; PEERS=<runner> names another, PEERS=none
# skips the peer codes.
PEERS ?= $(firstword $(wildcard $(CURDIR)/../shared/peers/run            $(shell git rev-parse --path-format=absolute --git-common-dir 2>/dev/null)/../../shared/peers/run))
bench: examples
	$(ENV) cargo build --release -p gimlet-validate --bin gimlet-bench -j $(JOBS)
	@t0=$$(date +%s); $(ENV) /usr/bin/python3 scripts/bench.py --build $(BUILD) --out results/bench.json \
	  --kernel-exe $(CARGO_TARGET_DIR)/release/gimlet-bench --peers "$(or $(PEERS),none)" && \
	/usr/bin/python3 scripts/bench_docs.py results/bench.json docs/performance.md && \
	echo "=== make bench: $$(( $$(date +%s) - t0 )) s; results/bench.json, docs/performance.md speed table"

# The MPI check of the io layer (crates/gimlet-validate, gimlet-io-check) on
# 1 and 2 ranks: distributed HDF5 datasets with uneven and empty ranks,
# attributes, the messages of bad reads, rejected files (foreign, truncated,
# wrong kind or version), XDMF, atomic writes, the CSV series, and a whole
# simulation's checkpoint (one and two levels) read back field by field and
# continued bitwise.
io-check:
	$(ENV) cargo build --release -p gimlet-validate --bin gimlet-io-check -j $(JOBS)
	for n in 1 2; do $(ENV) mpiexec -n $$n $(CARGO_TARGET_DIR)/release/gimlet-io-check || exit 1; done

# The main job's work-precision study (issue 27): the wedge loaded to
# 450 nm on 3 to 5 levels and on 3 levels with every cell halved and
# quartered (the converged reference, Richardson), uniform 125 nm cells,
# half the speed and a shorter step; prints the table, writes
# results/wedge_work_precision.{csv,json,png} and regenerates README.md's
# table and docs/wedge_work_precision.json (which make demo reads).
# About 30 minutes on 2 cores.
wedge-study: examples
	$(ENV) /usr/bin/python3 scripts/wedge_study.py --np $(NP) --out results --build $(BUILD)

# Coulomb friction at the indenter: the J2 wedge
# nanoindentation (wedge_indentation --material j2 at its J2 validation
# resolution, loaded and unloaded) with mu = 0, 0.1, 0.2 and 0.3; prints
# the table, writes results/friction_study.csv and regenerates README.md's
# friction table. About 80 s on 2 cores.
friction-study: examples
	$(ENV) /usr/bin/python3 scripts/friction_study.py --np $(NP) --out results --build $(BUILD)

# The same for the Berkovich-equivalent cone (axisymmetric): cone_indentation
# --friction mu on 3 levels (126 nm finest cells), J2 aluminium to 300 nm and
# back, mu = 0, 0.1, 0.2 and 0.3; prints the table (load, pile-up, residual
# depth, Oliver-Pharr and true-area hardness and modulus, friction
# dissipation), writes results/friction_study_cone.csv and regenerates
# README.md's cone friction table. About 2 min with NP=1 (28 s a run; 2 ranks
# give the same figures bit for bit).
friction-study-cone: examples
	$(ENV) /usr/bin/python3 scripts/friction_study.py --scene cone --np $(NP) --out results --build $(BUILD)

# A scratch: the wedge pressed 400 nm into J2 aluminium, dragged 6 um
# sideways at mu = 0.2 on 3 levels that cover the track, lifted off; the
# force series, the groove and results/scratch.png. About 30 s on 2 cores.
scratch: examples
	@t0=$$(date +%s); $(ENV) mpiexec -n $(NP) $(BUILD)/examples-c/scratch --out results && \
	/usr/bin/python3 scripts/plot_scratch.py results scratch && \
	echo "=== make scratch: $$(( $$(date +%s) - t0 )) s; results/scratch.csv (time_s, x_tip_m, depth_m, fx_n_per_m, fy_n_per_m, ...), scratch_groove.csv, scratch.json, scratch.xdmf + scratch_*.h5, scratch.png"

# The Berkovich-equivalent cone nanoindentation (axisymmetric): a 70.3 deg
# cone pushed 300 nm into J2 aluminium on 4 levels (63 nm finest cells) and
# withdrawn; Oliver-Pharr's hardness and modulus against the inputs, the
# true contact area, the pile-up and results/cone.png. About 2.5 min on 2
# cores.
cone: examples
	@t0=$$(date +%s); $(ENV) mpiexec -n $(NP) $(BUILD)/examples-c/cone_indentation --out results && \
	/usr/bin/python3 scripts/plot_cone.py results cone && \
	echo "=== make cone: $$(( $$(date +%s) - t0 )) s; results/cone.csv (time_s, depth_m, load_n, ...), cone_surface.csv, cone_field.csv, cone.json, cone.xdmf + cone_*.h5, cone.png"

# The paper's 5-level multiscale indentation (0.25 mm workpiece, 61 nm
# particles at the tip, 150 m/s to 9.8 um and back), and the same scene with
# 4, 5 and 6 levels side by side.
multiscale: examples
	@t0=$$(date +%s); $(ENV) mpiexec -n $(NP) $(BUILD)/examples-c/multiscale_indentation --out results && \
	/usr/bin/python3 scripts/plot_multiscale.py results multiscale && \
	echo "=== make multiscale: $$(( $$(date +%s) - t0 )) s; results/multiscale.csv, multiscale_*.csv, multiscale.xdmf, multiscale.png"

multiscale-levels: examples
	for l in 4 5 6; do $(ENV) mpiexec -n $(NP) $(BUILD)/examples-c/multiscale_indentation --levels $$l \
	  --name multiscale$$l --out results --every 1000 || exit 1; done
	/usr/bin/python3 scripts/plot_multiscale.py results multiscale5 multiscale4 multiscale6

pressure-demo: examples
	$(ENV) mpiexec -n $(NP) $(BUILD)/examples-c/pressure_indentation --levels 3 --steps 2000 --out results
	/usr/bin/python3 scripts/plot_indentation.py results

# The last line is ctest's count restated as "ctest: N passed, M failed".
test:
	@rm -f $(BUILD)/ctest.log; \
	TIMEFORMAT="=== make test: %1R s wall, %1U s user + %1S s system CPU in all"; \
	time $(MAKE) --no-print-directory test-stages; rc=$$?; \
	[ $$rc -eq 0 ] || echo "=== make test: FAILED"; \
	if [ -f $(BUILD)/ctest.log ]; then \
	  sed -n 's/.*tests passed, \([0-9]*\) tests\{0,1\} failed out of \([0-9]*\).*/\1 \2/p' $(BUILD)/ctest.log | \
	  { read -r failed total && echo "ctest: $$((total - failed)) passed, $$failed failed"; }; \
	fi; \
	exit $$rc

# The stages of make test. `cargo test --no-run` compiles first, with both
# cores busy (the library and its unit tests build side by side); the CMake
# build then finds the library current and builds the C programs; clippy
# checks in the release profile, so it reuses the build scripts' runs
# (bindgen) of the release build.
test-stages:
	$(call stage,setup,bash scripts/setup.sh)
	$(call stage,cargo fmt --check,cargo fmt --all -- --check)
	$(call stage,cargo build (library and tests),cargo test --release --workspace --no-run -j $(JOBS))
	$(call stage,cmake configure,cmake -S . -B $(BUILD) $(CMAKE_ARGS))
	$(call stage,cmake build,cmake --build $(BUILD) -j $(JOBS))
	$(call stage,cmake install,cmake --install $(BUILD) --prefix $(PREFIX))
	$(call stage,cargo test --release,cargo test --release --workspace --no-fail-fast -j $(JOBS))
	$(call stage,cargo clippy,cargo clippy --release --workspace --all-targets -j $(JOBS) -- -D warnings)
	$(call stage,ctest,ctest --test-dir $(BUILD) --output-on-failure -j $(JOBS) | tee $(BUILD)/ctest.log)

clean:
	rm -rf $(BUILD) $(PREFIX)
