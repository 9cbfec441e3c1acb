# Every developer command of rperc. `make demo` sets up a fresh machine and runs the
# main demo; `make test` runs every test; `make check` is what CI runs.
PY ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed

.PHONY: demo install develop test test-rust test-python lint fmt bench bench-json docs check clean

# The JSON keeps each demo's measured figures and printed line for the docs.
demo: install
	$(BIN)/rperc demo all --out out/demo --json out/demo/demo.json

# The Python environment: rperc (editable) with its test extras, every dependency
# read from pyproject.toml (one list, there; .ci/requirements.py prints it), and
# maturin for fast rebuilds of the extension. pip installs the dependencies while
# cargo builds the extension, instead of after it as `pip install -e ".[extras]"`
# does; the editable install then finds the build done.
EXTRAS := test geo viz docs
$(STAMP): pyproject.toml
	test -x $(BIN)/python || $(PY) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip "maturin>=1.9.4,<2"
	$(BIN)/python .ci/requirements.py $(EXTRAS) > $(VENV)/requirements.txt
	$(BIN)/python -m pip install --quiet -r $(VENV)/requirements.txt & pip=$$!; \
	  . $(BIN)/activate && maturin develop --release --quiet --skip-install; built=$$?; \
	  wait $$pip && test $$built = 0
	$(BIN)/python -m pip install --quiet --no-deps --no-build-isolation -e .
	touch $(STAMP)

install: $(STAMP) develop

# Rebuilds the extension in place. pip has installed rperc (editable) and every
# dependency already; letting maturin install them again would print a line of pip's
# "Ignoring ...: markers 'extra == ...' don't match" per optional dependency.
develop: $(STAMP)
	. $(BIN)/activate && maturin develop --release --quiet --skip-install

test: install test-rust test-python

# Incremental compilation only pays on a rebuild; from a fresh clone it costs about a
# fifth of the test build (CARGO_INCREMENTAL=1 make test-rust to iterate).
test-rust:
	. $(BIN)/activate && CARGO_INCREMENTAL=$${CARGO_INCREMENTAL:-0} cargo test --workspace

# pytest exits 5 when it collects nothing; that is a failure here, not a pass. The
# tests run on every core (pytest-xdist); each is independent of the others' order.
test-python:
	. $(BIN)/activate && python -m pytest -n auto

lint: $(STAMP)
	cargo fmt --all -- --check
	cargo clippy --workspace --all-targets --all-features -- -D warnings
	$(BIN)/ruff check python tests benchmarks docs/hooks
	. $(BIN)/activate && python -m mypy.stubtest rperc._rperc
	. $(BIN)/activate && python -m mypy --strict python/rperc

fmt:
	cargo fmt --all
	$(BIN)/ruff check --fix python tests benchmarks docs/hooks
	$(BIN)/ruff format python tests benchmarks docs/hooks

bench: install
	cargo bench --workspace --features bench
	. $(BIN)/activate && for b in benchmarks/*.py; do python $$b; done

# The short benchmark suites whose JSON summaries the docs' benchmarks page renders
# (docs/hooks/benchmarks.py); with no data folder the page says so instead.
BENCH := out/bench
bench-json: install
	mkdir -p $(BENCH)
	. $(BIN)/activate && D=$$(python -c "from rperc.datasets import data_dir; print(data_dir() or '')") \
	&& if [ -z "$$D" ]; then echo "bench-json: no data folder (RPERC_DATA), nothing measured"; exit 0; fi \
	&& rperc bench laser --logs $$D/carmen --seeds 0-1 --variants odometry,plain,laser --json $(BENCH)/laser.json \
	&& rperc bench mrclam --robots 1-3 --variants plain,anchor,external,smooth --json $(BENCH)/mrclam.json \
	&& rperc bench mrclam --robots 1-3 --variants plain,anchor,external,smooth --span 444 1e9 --json $(BENCH)/mrclam-heldout.json \
	&& rperc bench track --corpus $$D/otb/Girl --trackers color-template,color,csrt,kcf --json $(BENCH)/track.json \
	&& rperc bench pattern --steps 3 --seeds 10-12 --trackers rperc,ecc-affine --json $(BENCH)/pattern.json

# The documentation site, warnings as errors; figures from out/demo when `make demo`
# has drawn them, benchmark tables from out/bench.
docs: bench-json
	. $(BIN)/activate && NO_MKDOCS_2_WARNING=1 mkdocs build --strict

check: install lint test docs

clean:
	rm -rf $(VENV) target out
