# `make`       synthesise and certify every controller, build every FMU into dist/, validate
#              them, run the closed-loop comparison (results/report.md) and print its summary
# `make test`  every test: rustfmt and clippy, Rust (unit + integration, incl. the fmi crate loading
#              dist/) and pytest
# `make bench` benchmarks (criterion)
# `make constrained` (opt-in) the designs with the thesis's limits imposed as LMIs
# `make comfort` (work in progress) the comfort designs and their FMUs in dist/comfort/
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

CONTROLLERS := hinf_sf hinf_of hinf_of_aw robust_sf robust_of delay_sf ft_of
FMUS := road plant $(CONTROLLERS)
FMU_FILES := $(FMUS:%=dist/%.fmu)
RUST_SOURCES := $(shell find vehicle fmu-core fmu-plant fmu-controller fmu-road fmu-pack synth master -name '*.rs' -o -name '*.json' -o -name Cargo.toml) Cargo.toml

.PHONY: all setup fmus validate compare sweep constrained comfort test lint test-rust test-python bench descriptions readme clean

all: fmus validate compare sweep
	@echo
	@echo "Built: $(FMU_FILES); report: results/report.md"

# The robustness sweep (README "Robustness sweeps"): sprung mass x actuator delay x road seed.
sweep: $(FMU_FILES) $(STAMP)/release
	./target/release/master sweep sweeps/mass_delay.json --out results/sweep
	@sed -n '/^## Limits/,/^## Metrics/p' results/sweep/report.md | sed '$$d'

# Every scenario of scenarios/ with the passive car and each controller (master, in parallel):
# results/report.md with the tables, the plots and the synthesis summary.
compare: $(FMU_FILES) $(STAMP)/release
	./target/release/master compare --scenarios scenarios --controllers $(call commas,$(CONTROLLERS)) --out results --designs dist/synthesis.json

# Work in progress (README "Comfort designs"): every variant designed for ISO 2631 comfort on an
# ISO 8608 road (synth/designs/comfort.json), certified against an exact frequency-domain
# prediction: dist/comfort/<variant>.certificate.json, controller.json, synthesis.md and an FMU
# of each design synthesis produced (a refused design is reported in synthesis.md and gets none),
# beside copies of road.fmu and plant.fmu, and their comparison on scenarios/ with the predicted
# figure beside the measured ones (results/comfort/report.md). About a minute. `make test` builds
# the FMUs: their co-simulation is tested against their certificates' predictions.
comfort: $(STAMP)/comfort-fmus
	ctrls=$$(cd dist/comfort && ls *.fmu | grep -v -e '^road\.fmu' -e '^plant\.fmu' | sed 's/\.fmu$$//' | paste -sd, -); \
	./target/release/master --dist dist/comfort compare --scenarios scenarios --controllers $$ctrls --out results/comfort --designs dist/comfort/synthesis.json

$(STAMP)/comfort: $(STAMP)/release synth/designs/comfort.json
	./target/release/synth --design synth/designs/comfort.json --out dist/comfort
	@touch $@

$(STAMP)/comfort-fmus: $(STAMP)/comfort dist/road.fmu dist/plant.fmu
	cp dist/road.fmu dist/plant.fmu dist/comfort/
	for d in dist/comfort/*/controller.json; do v=$$(basename $$(dirname $$d)); \
	  ./target/release/fmu-pack fmu --lib target/release/libfmu_controller.so --resources dist/comfort/$$v --out dist/comfort/$$v.fmu || exit 1; done
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
	@missing=$$(for p in $(APT_PACKAGES); do dpkg-query -W -f='$${Status}' $$p 2>/dev/null | grep -q "ok installed" || echo $$p; done); \
	if [ -n "$$missing" ]; then \
	  echo "Installing Debian packages: $$missing"; \
	  $(SUDO) apt-get update -qq && DEBIAN_FRONTEND=noninteractive $(SUDO) apt-get install -y -qq $$missing; \
	fi
	@if ! $(PYTHON) -c 'import venv, ensurepip' 2>/dev/null; then \
	  DEBIAN_FRONTEND=noninteractive $(SUDO) apt-get install -y -qq python3-venv; fi
	@touch $@

$(STAMP)/venv: tests/python/requirements.txt python/pyproject.toml | $(STAMP)/apt
	@mkdir -p $(STAMP)
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install -q --upgrade pip
	$(PY) -m pip install -q -r tests/python/requirements.txt
	$(PY) -m pip install -q -e python
	@touch $@

fmus: $(FMU_FILES) dist/OspSystemStructure.xml dist/car.ssp

# One cargo build for all FMU libraries and the packager; then one fmu-pack call per FMU.
$(STAMP)/release: $(RUST_SOURCES) | $(STAMP)/apt
	@mkdir -p $(STAMP)
	$(CARGO) build --release -p fmu-road -p fmu-plant -p fmu-controller -p fmu-pack -p synth -p master
	@touch $@

dist/plant.fmu: $(STAMP)/release
	./target/release/fmu-pack fmu --lib target/release/libfmu_plant.so --out $@

dist/road.fmu: $(STAMP)/release
	./target/release/fmu-pack fmu --lib target/release/libfmu_road.so --out $@

# Synthesise and certify every controller (a failed certificate stops here: no FMU).
$(STAMP)/synth: $(STAMP)/release synth/designs/default.json
	./target/release/synth --design synth/designs/default.json --out dist $(CONTROLLERS)
	@touch $@

$(CONTROLLERS:%=dist/%.fmu): dist/%.fmu: $(STAMP)/synth
	./target/release/fmu-pack fmu --lib target/release/libfmu_controller.so --resources dist/$* --out $@

# The same loop as an OSP system structure beside the FMUs, for libcosim and OSP tools
# (tests/python/test_libcosim.py runs it).
dist/OspSystemStructure.xml: $(FMU_FILES) $(STAMP)/release scenarios/bump.json
	./target/release/master osp --scenario scenarios/bump.json --controller hinf_of --out $@

# And as an SSP 1.0 archive (SystemStructure.ssd + the three FMUs) for SSP-capable tools
# (tests/python/test_ssp.py validates it against the SSP schema and runs it in FMPy).
dist/car.ssp: $(FMU_FILES) $(STAMP)/release scenarios/bump.json
	./target/release/master ssp --scenario scenarios/bump.json --controller hinf_of --out $@

validate: $(FMU_FILES) $(STAMP)/venv
	@for f in $(FMU_FILES); do echo "fmpy validate $$f"; $(VENV)/bin/fmpy validate $$f || exit 1; done

# Regenerate the checked-in modelDescription/*.xml and the README's variable table after a
# change of a variable table (a test fails until you do and commit them).
descriptions: $(STAMP)/release
	./target/release/fmu-pack description --lib target/release/libfmu_plant.so --xml modelDescription/plant.xml --readme README.md --tag plant-variables
	./target/release/fmu-pack description --lib target/release/libfmu_road.so --xml modelDescription/road.xml --readme README.md --tag road-variables
	./target/release/fmu-pack glibc --lib target/release/libfmu_plant.so --lib target/release/libfmu_road.so --lib target/release/libfmu_controller.so --readme README.md --tag platform

readme: descriptions

test: lint test-rust test-python

# The tree stays rustfmt-formatted and clippy-clean: a warning fails the tests.
lint: | $(STAMP)/apt
	$(CARGO) fmt --all -- --check
	$(CARGO) clippy --workspace --all-targets -- -D warnings

test-rust: $(FMU_FILES) $(STAMP)/comfort-fmus | $(STAMP)/apt
	$(CARGO) test --workspace

test-python: $(FMU_FILES) dist/OspSystemStructure.xml dist/car.ssp $(STAMP)/venv $(STAMP)/release
	$(PY) -m pytest tests/python -q

$(STAMP)/venv-bench: bench/requirements.txt | $(STAMP)/venv
	$(PY) -m pip install -q -r bench/requirements.txt
	@touch $@

# Benchmarks: one fmi2DoStep of the plant (criterion), each synthesis against the same LMIs
# in CVXPY + Clarabel (Python) in the same run, every design together (wall time), and a 10 s
# closed loop in the Rust master against the same loop in FMPy.
bench: $(FMU_FILES) $(STAMP)/venv-bench
	$(CARGO) bench -p fmu-plant --bench do_step
	$(CARGO) bench -p vehicle --bench road
	$(PY) bench/synth_vs_cvxpy.py
	./target/release/synth --design synth/designs/default.json --out $(STAMP)/bench-synth
	$(PY) bench/master_vs_fmpy.py

clean:
	rm -rf dist results $(STAMP)
	$(CARGO) clean
