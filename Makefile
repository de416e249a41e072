# `make`       synthesise and certify every controller (the comfort designs of
#              synth/designs/comfort.json), build every FMU into dist/, validate them, run the
#              closed-loop comparison (results/report.md) and print its summary
# `make test`  every test: rustfmt, clippy and rustdoc, Rust (unit + integration, incl. the fmi crate loading
#              dist/) and pytest
# `make check`  the quick inner loop: rustfmt, clippy and every crate's unit tests (no FMUs built)
# `make bench` benchmarks (criterion)
# `make bench-floor` (opt-in) the closed loop of `make bench` with the FMUs' products free (bench/floor.py)
# `make CROSS=0 …` the fast path: this machine's linux64 libraries only (no win64, no ARM)
# `make thesis` (opt-in) the thesis's H-inf designs (synth/designs/thesis.json) in dist/thesis/
# `make constrained` (opt-in) the thesis designs with their limits imposed as LMIs
# Everything the commands need is installed here: Debian packages and a .venv with FMPy.

SHELL := /bin/bash
.DEFAULT_GOAL := all

CARGO  ?= cargo
PYTHON ?= python3
VENV   := .venv
PY     := $(VENV)/bin/python
STAMP  := .make
# A word list as master's comma-separated --controllers.
commas = $(shell echo $(1) | tr ' ' ',')
# libclang-dev + clang: bindgen in the fmi crate's fmi-sys; pkg-config, libopenblas-dev, gfortran:
# clarabel's SDP support linked to Debian's OpenBLAS (synthesis).
APT_PACKAGES := pkg-config libclang-dev clang libopenblas-dev gfortran
SUDO := $(shell [ "$$(id -u)" = 0 ] || echo sudo)
# Install those of the Debian packages $(1) that are missing.
apt_install = missing=$$(for p in $(1); do dpkg-query -W -f='$${Status}' $$p 2>/dev/null | grep -q "ok installed" || echo $$p; done); \
	if [ -n "$$missing" ]; then \
	  echo "Installing Debian packages: $$missing"; \
	  $(SUDO) apt-get update -qq && DEBIAN_FRONTEND=noninteractive $(SUDO) apt-get install -y -qq $$missing; \
	fi

# Platforms (README "Platforms"). CROSS=1: every FMU of dist/ carries binaries/linux64 (x86-64,
# linked by zig against glibc 2.17 with cargo-zigbuild) and binaries/win64 (MinGW-w64), and
# dist/linux-aarch64/ holds the same FMUs for 64-bit ARM Linux (the AArch64 library in linux64,
# where FMI 2 importers on ARM look). rustup here has no other target's std, so win64 and
# aarch64 use Debian's rustc-web, building std from rust-web-src (-Zbuild-std, which needs
# RUSTC_BOOTSTRAP on a stable compiler). The tests run each platform's libraries in a C harness
# (tests/harness/) natively, under wine and under qemu-aarch64.
CROSS ?= 1
CROSS_APT := rustc-web cargo-web rust-web-src gcc-mingw-w64-x86-64 gcc-aarch64-linux-gnu libc6-dev-arm64-cross wine64 qemu-user
CROSS_DIR := target/cross
DEBIAN_RUST := RUSTC_BOOTSTRAP=1 RUSTC=/usr/bin/rustc CARGO=/usr/bin/cargo
BUILD_STD := -Zbuild-std=std,panic_unwind
# The FMU libraries and the panic probe (fmu-core/examples/panic_probe.rs) in one build per target.
CROSS_CRATES := -p fmu-road -p fmu-plant -p fmu-controller -p fmu-core --lib --example panic_probe
ZIG := PATH=$(CURDIR)/$(VENV)/bin:$$PATH cargo-zigbuild zigbuild --release --target-dir $(CROSS_DIR)
HARNESS_CC := -std=gnu99 -O2 -Wall -Wextra -Werror

# The variants, as synth's registry lists them (`synth --list`), and those with a thesis design
# (`synth --list-thesis`; `skyhook` and `lqg` have none).
CONTROLLERS := hinf_sf hinf_of hinf_of_aw robust_sf robust_of delay_sf ft_of skyhook lqg
THESIS_CONTROLLERS := hinf_sf hinf_of hinf_of_aw robust_sf robust_of delay_sf ft_of
FMUS := road plant $(CONTROLLERS)
FMU_FILES := $(FMUS:%=dist/%.fmu)
# The same FMUs as FMI 3.0 (README "Platforms"): one archive per FMU with every platform's
# library, from the same build (each library exports FMI 2.0's and FMI 3.0's functions).
FMI3_FMU_FILES := $(FMUS:%=dist/fmi3/%.fmu)
ifeq ($(CROSS),1)
# The linux64 library of each FMU, and the options that add the other platforms' libraries.
linux64_lib = $(CROSS_DIR)/x86_64-unknown-linux-gnu/release/libfmu_$(1).so
other_libs = --binary win64=$(CROSS_DIR)/x86_64-pc-windows-gnu/release/fmu_$(1).dll
fmi3_libs = --binary x86_64-windows=$(CROSS_DIR)/x86_64-pc-windows-gnu/release/fmu_$(1).dll --binary aarch64-linux=$(CROSS_DIR)/aarch64-unknown-linux-gnu/release/libfmu_$(1).so
LIBS := $(STAMP)/cross
ARM_FMU_FILES := $(FMUS:%=dist/linux-aarch64/%.fmu)
HARNESSES := target/harness/linux64/fmu_harness target/harness/win64/fmu_harness.exe target/harness/win64/bcryptprimitives.dll target/harness/linux-aarch64/fmu_harness
# One FMU per folder for the README's platform table.
PLATFORM_FMUS := dist/plant.fmu dist/linux-aarch64/plant.fmu
else
linux64_lib = target/release/libfmu_$(1).so
other_libs =
fmi3_libs =
LIBS := $(STAMP)/release
ARM_FMU_FILES :=
HARNESSES :=
PLATFORM_FMUS := dist/plant.fmu
endif
RUST_SOURCES := $(shell find linsys vehicle fmu-core fmu-plant fmu-controller controller-file fmu-road fmu-pack synth master -name '*.rs' -o -name '*.json' -o -name Cargo.toml) Cargo.toml

.PHONY: all setup fmus harnesses validate compare sweep constrained thesis test check lint test-rust test-python bench bench-floor descriptions schemas readme clean

all: fmus validate compare sweep
	@echo
	@echo "Built: $(FMU_FILES); report: results/report.md"

# The robustness sweep (README "Robustness sweeps"): sprung mass x actuator delay x road seed.
sweep: $(FMU_FILES) $(STAMP)/release
	./target/release/master sweep sweeps/mass_delay.json --out results/sweep
	@sed -n '/^## Limits/,/^## Metrics/p' results/sweep/report.md | sed '$$d'

# Every scenario of scenarios/ with the passive car and each controller (master, in parallel):
# results/report.md with the tables, the plots and the synthesis summary.
compare: $(FMU_FILES) $(FMI3_FMU_FILES) $(STAMP)/release
	./target/release/master compare --scenarios scenarios --controllers $(call commas,$(CONTROLLERS)) --out results --designs dist/synthesis.json

# Opt-in (docs/thesis-designs.md): the thesis's designs (synth/designs/thesis.json,
# certified H-inf norm gamma) in dist/thesis/ beside copies of road.fmu and plant.fmu, compared
# over scenarios/ into results/thesis/report.md. `make test` builds their FMUs: the tests of the
# H-inf machinery (Riccati, SciPy and co-simulation references) check them.
thesis: $(STAMP)/thesis-fmus
	./target/release/master --dist dist/thesis compare --scenarios scenarios --controllers $(call commas,$(THESIS_CONTROLLERS)) --out results/thesis --designs dist/thesis/synthesis.json

$(STAMP)/thesis: $(STAMP)/release synth/designs/thesis.json
	./target/release/synth --design synth/designs/thesis.json --out dist/thesis $(THESIS_CONTROLLERS)
	@touch $@

$(STAMP)/thesis-fmus: $(STAMP)/thesis dist/road.fmu dist/plant.fmu
	cp dist/road.fmu dist/plant.fmu dist/thesis/
	for v in $(THESIS_CONTROLLERS); do \
	  ./target/release/fmu-pack fmu --lib target/release/libfmu_controller.so --resources dist/thesis/$$v --out dist/thesis/$$v.fmu || exit 1; done
	@touch $@

# Opt-in: thesis ch. 5 with its limits imposed as LMIs (synth/designs/constrained.json: shaped
# road, 2.5 cm design bump) for the designs that impose them, compared like the shipped ones:
# dist/constrained/ and results/constrained/report.md (README "Constraint LMIs"). One to two minutes;
# the output feedback (`hinf_of`, one SDP of about 4 minutes) is left out.
CONSTRAINED := hinf_sf robust_sf
constrained: dist/road.fmu dist/plant.fmu $(STAMP)/release
	./target/release/synth --design synth/designs/constrained.json --out dist/constrained $(CONSTRAINED)
	cp dist/road.fmu dist/plant.fmu dist/constrained/
	for v in $(CONSTRAINED); do ./target/release/fmu-pack fmu --lib target/release/libfmu_controller.so --resources dist/constrained/$$v --out dist/constrained/$$v.fmu || exit 1; done
	./target/release/master --dist dist/constrained compare --scenarios scenarios --controllers $(call commas,$(CONSTRAINED)) --out results/constrained --designs dist/constrained/synthesis.json

setup: $(STAMP)/apt $(STAMP)/venv

$(STAMP)/apt:
	@mkdir -p $(STAMP)
	@$(call apt_install,$(APT_PACKAGES))
	@if ! $(PYTHON) -c 'import venv, ensurepip' 2>/dev/null; then \
	  DEBIAN_FRONTEND=noninteractive $(SUDO) apt-get install -y -qq python3-venv; fi
	@touch $@

# The cross toolchains (CROSS=1): Debian packages, and cargo-zigbuild with zig from PyPI.
$(STAMP)/apt-cross: | $(STAMP)/apt
	@$(call apt_install,$(CROSS_APT))
	@touch $@

$(STAMP)/zig: tests/harness/requirements.txt | $(STAMP)/venv
	$(PY) -m pip install -q -r tests/harness/requirements.txt
	@touch $@

$(STAMP)/venv: tests/python/requirements.txt python/pyproject.toml | $(STAMP)/apt
	@mkdir -p $(STAMP)
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install -q --upgrade pip
	$(PY) -m pip install -q -r tests/python/requirements.txt
	$(PY) -m pip install -q -e python
	@touch $@

fmus: $(FMU_FILES) $(ARM_FMU_FILES) $(FMI3_FMU_FILES) dist/OspSystemStructure.xml dist/car.ssp

# One cargo build for all FMU libraries and the packager; then one fmu-pack call per FMU.
$(STAMP)/release: $(RUST_SOURCES) | $(STAMP)/apt
	@mkdir -p $(STAMP)
	$(CARGO) build --release -p fmu-road -p fmu-plant -p fmu-controller -p fmu-pack -p synth -p master
	@touch $@

# The FMU libraries of every platform (CROSS=1), each with the panic probe.
$(STAMP)/cross: $(RUST_SOURCES) | $(STAMP)/apt-cross $(STAMP)/zig
	@mkdir -p $(STAMP)
	$(ZIG) --target x86_64-unknown-linux-gnu.2.17 $(CROSS_CRATES)
	$(DEBIAN_RUST) CARGO_TARGET_X86_64_PC_WINDOWS_GNU_LINKER=x86_64-w64-mingw32-gcc \
	  /usr/bin/cargo build --release $(BUILD_STD) --target x86_64-pc-windows-gnu --target-dir $(CROSS_DIR) $(CROSS_CRATES)
	$(DEBIAN_RUST) $(ZIG) $(BUILD_STD) --target aarch64-unknown-linux-gnu.2.17 $(CROSS_CRATES)
	@touch $@

dist/plant.fmu dist/road.fmu: dist/%.fmu: $(STAMP)/release $(LIBS)
	./target/release/fmu-pack fmu --lib $(call linux64_lib,$*) $(call other_libs,$*) --out $@

dist/fmi3/plant.fmu dist/fmi3/road.fmu: dist/fmi3/%.fmu: $(STAMP)/release $(LIBS)
	./target/release/fmu-pack fmu --fmi 3 --lib $(call linux64_lib,$*) $(call fmi3_libs,$*) --out $@

$(CONTROLLERS:%=dist/fmi3/%.fmu): dist/fmi3/%.fmu: $(STAMP)/synth $(LIBS)
	./target/release/fmu-pack fmu --fmi 3 --lib $(call linux64_lib,controller) $(call fmi3_libs,controller) --resources dist/$* --out $@

# The same FMUs for ARM: the AArch64 library in binaries/linux64 (README "Platforms").
dist/linux-aarch64/plant.fmu dist/linux-aarch64/road.fmu: dist/linux-aarch64/%.fmu: $(STAMP)/release $(LIBS)
	./target/release/fmu-pack fmu --lib $(call linux64_lib,$*) --binary linux64=$(CROSS_DIR)/aarch64-unknown-linux-gnu/release/libfmu_$*.so --out $@

$(CONTROLLERS:%=dist/linux-aarch64/%.fmu): dist/linux-aarch64/%.fmu: $(STAMP)/synth $(LIBS)
	./target/release/fmu-pack fmu --lib $(call linux64_lib,controller) --binary linux64=$(CROSS_DIR)/aarch64-unknown-linux-gnu/release/libfmu_controller.so --resources dist/$* --out $@

# The C harness of tests/python/test_platforms.py, built with each platform's compiler.
harnesses: $(HARNESSES)
target/harness/linux64/fmu_harness: tests/harness/fmu_harness.c | $(STAMP)/apt-cross
	@mkdir -p $(@D)
	gcc $(HARNESS_CC) -o $@ $< -ldl
target/harness/win64/fmu_harness.exe: tests/harness/fmu_harness.c | $(STAMP)/apt-cross
	@mkdir -p $(@D)
	x86_64-w64-mingw32-gcc $(HARNESS_CC) -o $@ $<
target/harness/win64/bcryptprimitives.dll: tests/harness/bcryptprimitives.c | $(STAMP)/apt-cross
	@mkdir -p $(@D)
	x86_64-w64-mingw32-gcc $(HARNESS_CC) -shared -o $@ $< -ladvapi32
target/harness/linux-aarch64/fmu_harness: tests/harness/fmu_harness.c | $(STAMP)/apt-cross
	@mkdir -p $(@D)
	aarch64-linux-gnu-gcc $(HARNESS_CC) -o $@ $< -ldl

# Synthesise and certify every controller (a refused design stops here: no FMU).
$(STAMP)/synth: $(STAMP)/release synth/designs/comfort.json
	./target/release/synth --design synth/designs/comfort.json --out dist $(CONTROLLERS)
	@touch $@

$(CONTROLLERS:%=dist/%.fmu): dist/%.fmu: $(STAMP)/synth $(LIBS)
	./target/release/fmu-pack fmu --lib $(call linux64_lib,controller) $(call other_libs,controller) --resources dist/$* --out $@

# The same loop as an OSP system structure beside the FMUs, for libcosim and OSP tools
# (tests/python/test_libcosim.py runs it).
dist/OspSystemStructure.xml: $(FMU_FILES) $(STAMP)/release scenarios/bump.json
	./target/release/master osp --scenario scenarios/bump.json --controller hinf_of --out $@

# And as an SSP 1.0 archive (SystemStructure.ssd + the three FMUs) for SSP-capable tools
# (tests/python/test_ssp.py validates it against the SSP schema and runs it in FMPy).
dist/car.ssp: $(FMU_FILES) $(STAMP)/release scenarios/bump.json
	./target/release/master ssp --scenario scenarios/bump.json --controller hinf_of --out $@

validate: $(FMU_FILES) $(ARM_FMU_FILES) $(FMI3_FMU_FILES) $(STAMP)/venv
	@for f in $(FMU_FILES) $(ARM_FMU_FILES) $(FMI3_FMU_FILES); do echo "fmpy validate $$f"; $(VENV)/bin/fmpy validate $$f || exit 1; done

# Regenerate the checked-in modelDescription/*.xml and the README's variable and platform tables
# after a change of a variable table or a platform (a test fails until you do and commit them;
# the platform table is the shipped one only from a CROSS=1 build).
descriptions: $(STAMP)/release $(PLATFORM_FMUS)
	./target/release/fmu-pack description --lib target/release/libfmu_plant.so --xml modelDescription/plant.xml --xml3 modelDescription/fmi3/plant.xml --readme README.md --tag plant-variables
	./target/release/fmu-pack description --lib target/release/libfmu_road.so --xml modelDescription/road.xml --xml3 modelDescription/fmi3/road.xml --readme README.md --tag road-variables
ifeq ($(CROSS),1)
	./target/release/fmu-pack platforms $(PLATFORM_FMUS:%=--fmu %) --readme README.md --tag platform
else
	@echo "descriptions: README's platform table left as it is: it describes the CROSS=1 builds, which CROSS=0 does not make"
endif

# The JSON Schemas of scenario and sweep files, generated from the master's types (a test fails
# while the checked-in ones are stale).
schemas: $(STAMP)/release
	./target/release/master schema scenario > schemas/scenario.schema.json
	./target/release/master schema sweep > schemas/sweep.schema.json

# The figures of the README from the tools that measure them: the synthesis table, the
# comparison summary and the runs it flags (tests/python/test_metadata.py fails while the
# comparison is stale).
COMPARISON_SECTION := \#\# Summary: W_k RMS seat acceleration [m/s²]
LIMITS_SECTION := \#\# Limits and model validity
SPLIT_SECTION := \#\# Where the comfort comes from: body control and seat isolation
REAL_CAR_SECTION := \#\# On a real car
ORDERS_SECTION := \#\# Master orders
readme: descriptions schemas $(STAMP)/synth $(STAMP)/thesis compare
	./target/release/fmu-pack splice --from dist/synthesis.md --readme README.md --tag synthesis
	./target/release/fmu-pack splice --from dist/thesis/gamma.md --readme README.md --tag gamma
	./target/release/fmu-pack splice --from dist/car.md --readme README.md --tag modes
	./target/release/fmu-pack splice --from results/report.md --section "$(COMPARISON_SECTION)" --readme README.md --tag comparison
	./target/release/fmu-pack splice --from results/report.md --section "$(LIMITS_SECTION)" --readme README.md --tag limits
	./target/release/fmu-pack splice --from results/report.md --section "$(SPLIT_SECTION)" --readme README.md --tag split
	./target/release/fmu-pack splice --from results/report.md --section "$(REAL_CAR_SECTION)" --readme README.md --tag real-car
	./target/release/fmu-pack splice --from results/report.md --section "$(ORDERS_SECTION)" --readme README.md --tag orders

test: lint test-rust test-python

# The quick inner loop: what needs no FMU (format, lints, the unit tests next to the code).
check: lint
	$(CARGO) test --workspace --release --lib

# The tree stays rustfmt-formatted, clippy-clean and its docs build without a warning (a broken
# or private intra-doc link; a unit in brackets is written \[s\]): a warning fails the tests.
lint: | $(STAMP)/apt
	$(CARGO) fmt --all -- --check
	$(CARGO) clippy --workspace --all-targets -- -D warnings
	RUSTDOCFLAGS="-D warnings" $(CARGO) doc --workspace --no-deps

# In the release profile: the tests reuse `make`'s build of every dependency instead of a
# second full build in the test profile (5.6 GB of target/debug and several minutes on 2 cores;
# a CI run once ran out of disk in the pytest that followed it).
test-rust: $(FMU_FILES) $(FMI3_FMU_FILES) $(STAMP)/thesis-fmus | $(STAMP)/apt
	$(CARGO) test --workspace --release

# On every core (pytest-xdist), a test file per worker (a file's module fixtures, such as the
# other BLAS kernel's synthesis or the wine prefix, made once); the slowest tests listed.
test-python: $(FMU_FILES) $(ARM_FMU_FILES) $(FMI3_FMU_FILES) $(HARNESSES) dist/OspSystemStructure.xml dist/car.ssp $(STAMP)/thesis-fmus $(STAMP)/venv $(STAMP)/release compare
	FMU_CROSS=$(CROSS) $(PY) -m pytest tests/python -q -n auto --dist loadfile --durations=15

$(STAMP)/venv-bench: bench/requirements.txt | $(STAMP)/venv
	$(PY) -m pip install -q -r bench/requirements.txt
	@touch $@

# Benchmarks: one fmi2DoStep of the plant and one step of three shipped controllers
# (criterion), each synthesis against the same LMIs in CVXPY + Clarabel (Python) in the same
# run, every design together (wall time), a 10 s
# closed loop in the Rust master against the same loop in FMPy, and the 10 000-run sweep
# (sweeps/study_10k.json, about 3 minutes on 2 cores; its report in $(STAMP)/bench-study).
bench: $(FMU_FILES) $(STAMP)/venv-bench
	$(CARGO) bench -p fmu-plant --bench do_step
	$(CARGO) bench -p fmu-controller --bench step
	$(CARGO) bench -p vehicle --bench road
	$(PY) bench/synth_vs_cvxpy.py
	./target/release/synth --design synth/designs/comfort.json --out $(STAMP)/bench-synth
	./target/release/synth --design synth/designs/thesis.json --out $(STAMP)/bench-synth-thesis
	$(PY) bench/master_vs_fmpy.py
	./target/release/master sweep sweeps/study_10k.json --out $(STAMP)/bench-study

# The loop targets against a floor: the same loop with every matrix-vector product of the FMUs'
# steps free (bench/floor.py; builds the three FMUs from a patched copy into target/floor).
bench-floor: $(FMU_FILES) $(STAMP)/venv-bench
	$(PY) bench/floor.py

clean:
	rm -rf dist results $(STAMP)
	$(CARGO) clean
