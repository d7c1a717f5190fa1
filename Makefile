# Two entry points (see README): `make demo` and `make test`. Both create .venv and build the compiled agent
# (agent/native, Rust, cargo --locked) on first use.
PY ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed
# cargo from PATH, else rustup's default place (a fresh shell may not have ~/.cargo/bin on PATH yet)
CARGO ?= $(shell command -v cargo 2>/dev/null || echo $(HOME)/.cargo/bin/cargo)
NATIVE := agent/native
AGENT_BIN := $(NATIVE)/target/release/fluidswarm-agent
ROUTER_BIN := $(NATIVE)/target/release/fluidswarm-router
AGENT_SRC := $(NATIVE)/Cargo.toml $(NATIVE)/Cargo.lock $(wildcard $(NATIVE)/src/*.rs $(NATIVE)/src/*/*.rs)
# The extension module agent._native (agent/records.py): pip's editable install builds it in place. It wraps
# the agent crate's records (wire.rs, command.rs, ...), so a change there rebuilds it too ($(STAMP) below).
EXT_SRC := $(NATIVE)/python/Cargo.toml $(wildcard $(NATIVE)/python/src/*.rs)

.PHONY: demo test check install clean bench agent router-traffic crate-tests fuzz netfault-tools lint fmt scenarios

# The extension's target directory (pip's build, beside cargo's build of the programs in target/, so that neither
# waits for the other's lock). clippy (make lint) runs in target/ itself: its check build reuses the build scripts
# and proc-macros the programs' release build compiled (with ring's C) and compiles only pyo3's own; in a
# directory of its own it compiled all 109 of them again (on a clone with the programs built, clippy alone:
# 143 s, 250 s of CPU in target/check with pip's extension build there; 104 s, 173 s of CPU in target/).
EXT_DIR := $(CURDIR)/$(NATIVE)/target/ext

# The editable install: the Python dependencies and the extension module (pip, setuptools-rust). The programs
# are not pip's here (FLUIDSWARM_PROGRAMS=cargo, setup.py) but cargo's rule below, so that `make install` runs the
# two builds side by side (-j2): the programs' build alone keeps the 2 cores 1.8 busy (cargo --timings), pip's
# dependencies and the extension fill the rest instead of waiting for it (a fresh clone: 318 s, then 22 s and
# 47 s). The extension builds in $(EXT_DIR), so neither cargo waits for the other's lock. The dev path runs the
# programs from agent/native/target/release (swarmhost/executable.py).
$(STAMP): pyproject.toml setup.py constraints.txt $(EXT_SRC) $(AGENT_SRC)
	test -x $(BIN)/python || $(PY) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	FLUIDSWARM_PROGRAMS=cargo CARGO_TARGET_DIR=$(EXT_DIR) \
		$(BIN)/python -m pip install --quiet -c constraints.txt -e '.[test,lint]'
	touch $(STAMP)

# One cargo build makes both programs: the agent and the router of access level acl (swarmhost/router_process.py)
$(AGENT_BIN) $(ROUTER_BIN) &: $(AGENT_SRC)
	$(CARGO) build --release --locked --manifest-path $(NATIVE)/Cargo.toml
	touch $(AGENT_BIN) $(ROUTER_BIN)

agent: $(AGENT_BIN) $(ROUTER_BIN)

# The router that counts the state messages crossing to other routers (`fluidswarm router --count-traffic`,
# scripts/imitation_traffic.py): the same program with zenoh's statistics, which cost every message, so it is
# a program of its own (agent/native/Cargo.toml, feature traffic); tests/test_router_traffic.py runs it.
# Its build (137 s of a fresh clone, cargo --timings) is zenoh-transport and zenoh compiled again with statistics,
# one after the other on one core (73 s), then its own link on both (70 s): the release build's dependencies are
# LLVM bitcode only (every root of it is thin-LTO), so each program's link generates the machine code of all of
# zenoh (with -C lto=off still 62 s). `make test` builds it in cargo's lane, beside make lint.
ROUTER_TRAFFIC_BIN := $(NATIVE)/target/release/fluidswarm-router-traffic
$(ROUTER_TRAFFIC_BIN): $(AGENT_SRC) | $(AGENT_BIN)
	$(CARGO) build --release --locked --features traffic --bin fluidswarm-router-traffic --manifest-path $(NATIVE)/Cargo.toml
	touch $(ROUTER_TRAFFIC_BIN)

router-traffic: $(ROUTER_TRAFFIC_BIN)

# The Python side and the programs side by side (above)
install:
	+$(MAKE) --no-print-directory -j2 $(STAMP) $(AGENT_BIN)

demo: install
	$(BIN)/fluidswarm demo

# make test first builds what the tests run, in two lanes side by side on the 2 cores (make -j2, each target's output in
# one piece): pip (the Python dependencies, the extension module in target/ext) beside cargo's programs. Then the swarm
# tests marked `alone` (tests/conftest.py ALONE: they measure stalls, recoveries and the realtime factor in wall
# seconds, or inject faults whose effect is timed), one at a time. They keep only half a core busy (zenoh's lease,
# connect timeouts, frozen agents, clips played in real time), so the rest of the build runs beside them in the
# background at the idle scheduling class (chrt --idle: it gets only the CPU no test wants, and a test's process takes a
# core from it the moment it wakes): make lint, the counting router and the crate's tests (one target directory, so
# cargo runs their builds one after the other), ~420 s of CPU on a fresh clone, which no test but one waits for. setsid:
# their own process group, which an interrupted make test stops. Their output is printed once they are done (one piece
# per target). Then the unit tests (no processes) and the swarm tests that may share the machine, two at a time
# (pytest-xdist, worksteal: a worker that runs out takes the other's queue), with both cores to themselves; then
# tests/test_router_traffic.py, the one test that needs the counting router. Every part runs even when another failed,
# and `make test` fails if any did. Each run lists its slowest ten (docs/development.md).
IDLE := $(if $(shell command -v chrt 2>/dev/null),chrt --idle 0,nice -n 19)
BUILD_LOG := $(VENV)/make-test-build.log
test: netfault-tools
	+$(MAKE) --no-print-directory -j2 --output-sync=target $(STAMP) $(AGENT_BIN)
	setsid $(IDLE) $(MAKE) --no-print-directory -k -j2 --output-sync=target lint router-traffic crate-tests \
		> $(BUILD_LOG) 2>&1 & build=$$!; trap 'kill -TERM -'$$build' 2>/dev/null; exit 130' INT TERM; \
	$(BIN)/python -m pytest -q -m "alone and not every_scenario" --durations=10 tests; alone=$$?; \
	wait $$build; built=$$?; cat $(BUILD_LOG); echo "make test: lint, counting router, crate tests: rc $$built"; \
	$(BIN)/python -m pytest -q -n 2 --dist worksteal -m "not alone and not every_scenario" --durations=10 \
		--ignore tests/test_router_traffic.py tests; shared=$$?; \
	traffic=1; test ! -x $(ROUTER_TRAFFIC_BIN) || { \
		$(BIN)/python -m pytest -q tests/test_router_traffic.py; traffic=$$?; }; \
	test $$shared -eq 0 -a $$alone -eq 0 -a $$built -eq 0 -a $$traffic -eq 0

# The crate's tests are its library's, tests/ and the doctests (`--lib --tests`, then `--doc`: cargo refuses them
# in one call): a bare `cargo test` also builds the examples, bare_exchange one more thin-LTO link of zenoh (70 s
# of 74 s on a fresh clone, cargo --timings) for no test; clippy --all-targets (make lint) compiles the examples.
# After the counting router (order only): the same target directory, whose lock the two would otherwise wait on.
# MAKEFLAGS= for the doctests: under make -j2 it names a jobserver whose descriptors a recipe without `+` does
# not get, and rustdoc warns about them (cargo, as in the other lane, runs its own jobs).
crate-tests: | $(ROUTER_TRAFFIC_BIN)
	$(CARGO) test --release --locked --lib --tests --manifest-path $(NATIVE)/Cargo.toml
	MAKEFLAGS= $(CARGO) test --release --locked --doc --manifest-path $(NATIVE)/Cargo.toml

# The quick loop while changing code: the linters and the unit tests (no processes), on both cores; about
# 2 minutes once installed. `make test` runs them too, and the swarm tests.
check: lint
	$(BIN)/python -m pytest -q -n 2 --dist worksteal -m "not swarm" tests

# Every small scenario end to end (make test runs one of each kind, tests/test_scenarios.py CORE): as make test
# does, the untimed ones two at a time, then the timed ones (tests/conftest.py ALONE) one after the other.
scenarios: install
	$(BIN)/python -m pytest -q -n 2 --dist worksteal -m "every_scenario and not alone" --durations=10 \
		tests/test_scenarios.py; shared=$$?; \
	$(BIN)/python -m pytest -q -m "every_scenario and alone" --durations=10 tests/test_scenarios.py; alone=$$?; \
	test $$shared -eq 0 -a $$alone -eq 0

# The network-fault tests (tests/test_netfaults.py) need nftables; CI runs as root on a fresh machine.
netfault-tools:
	@command -v nft >/dev/null 2>&1 || test "$$(id -u)" != 0 || apt-get install -y -q nftables >/dev/null \
		|| { apt-get update -q >/dev/null && apt-get install -y -q nftables >/dev/null; }

# `make fuzz` (not part of `make test`): every decoder's fuzz target for FUZZ_SECONDS each, or with FUZZ_RUNS=N
# to N inputs each (no time bound); inputs tried per target (fuzz/run.py, docs/benchmarks/fuzz.md). The Rust
# targets are built by cargo-fuzz (installed from crates.io on first use) with rustup's nightly toolchain,
# which libFuzzer's instrumentation needs; the Python ones run under atheris (the `fuzz` extra).
FUZZ_SECONDS ?= 30
FUZZ_RUNS ?=
FUZZ_STAMP := $(VENV)/.fuzz-installed
CARGO_FUZZ_VERSION := 0.13.2

$(FUZZ_STAMP): $(STAMP) pyproject.toml
	$(BIN)/python -m pip install --quiet -c constraints.txt -e '.[test,fuzz]'
	touch $(FUZZ_STAMP)

fuzz: $(FUZZ_STAMP)
	@$(CARGO) +nightly --version >/dev/null 2>&1 \
		|| { echo "make fuzz: needs rustup's nightly toolchain beside stable (rustup toolchain install nightly)"; exit 1; }
	$(CARGO) fuzz --version 2>/dev/null | grep -q '$(CARGO_FUZZ_VERSION)' \
		|| $(CARGO) install cargo-fuzz --version $(CARGO_FUZZ_VERSION) --locked
	CARGO=$(CARGO) $(BIN)/python fuzz/run.py $(if $(FUZZ_RUNS),--runs $(FUZZ_RUNS),--seconds $(FUZZ_SECONDS))

# Linters, formatters (in check mode) and type checks, pinned in pyproject.toml (the lint extra) and
# Cargo.lock; strictness and the rules left out, with why: pyproject.toml's [tool.ruff] and [tool.mypy].
# clippy and rustfmt come with rustup's default profile; a minimal toolchain gets them added first.
# Every check runs even when one failed, so one run names all there is to fix; `make lint` fails if any did.
RUSTUP ?= $(shell command -v rustup 2>/dev/null || echo $(HOME)/.cargo/bin/rustup)
CLIPPY_FMT := $(CARGO) clippy --version >/dev/null 2>&1 && $(CARGO) fmt --version >/dev/null 2>&1 \
	|| $(RUSTUP) component add clippy rustfmt
lint: $(STAMP)
	@$(CLIPPY_FMT)
	fail=0; \
	$(BIN)/ruff check . || fail=1; \
	$(BIN)/ruff format --check . || fail=1; \
	$(BIN)/mypy || fail=1; \
	$(CARGO) fmt --all --manifest-path $(NATIVE)/Cargo.toml --check || fail=1; \
	$(CARGO) clippy --release --workspace --all-targets --locked --manifest-path $(NATIVE)/Cargo.toml \
		-- -D warnings || fail=1; \
	test $$fail -eq 0

# The mechanical fixers: ruff's safe fixes (never --unsafe-fixes), then both formatters.
fmt: $(STAMP)
	@$(CLIPPY_FMT)
	$(BIN)/ruff check --fix --quiet . || true
	$(BIN)/ruff format .
	$(CARGO) fmt --all --manifest-path $(NATIVE)/Cargo.toml

bench: install
	$(BIN)/fluidswarm bench

clean:
	rm -rf $(VENV) build *.egg-info $(NATIVE)/target
