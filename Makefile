# Every developer command of rperc. `make demo` sets up a fresh machine and runs the
# main demo; `make test` runs every test; `make check` is what CI runs.
PY ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed

.PHONY: demo install develop test test-rust test-python lint fmt bench check clean

demo: install
	$(BIN)/rperc demo all --out out/demo

# The Python environment: rperc with its test extras, every dependency read from
# pyproject.toml (one list, there), then maturin for fast rebuilds of the extension.
$(STAMP): pyproject.toml
	test -x $(BIN)/python || $(PY) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e ".[test,geo,viz]" "maturin>=1.9.4,<2"
	touch $(STAMP)

install: $(STAMP) develop

develop: $(STAMP)
	. $(BIN)/activate && maturin develop --release --quiet

test: install test-rust test-python

test-rust:
	. $(BIN)/activate && cargo test --workspace

# pytest exits 5 when it collects nothing; that is a failure here, not a pass.
test-python:
	. $(BIN)/activate && python -m pytest

lint: $(STAMP)
	cargo fmt --all -- --check
	cargo clippy --workspace --all-targets -- -D warnings
	$(BIN)/ruff check python tests benchmarks
	. $(BIN)/activate && python -m mypy.stubtest rperc._rperc
	. $(BIN)/activate && python -m mypy --strict python/rperc

fmt:
	cargo fmt --all
	$(BIN)/ruff check --fix python tests benchmarks
	$(BIN)/ruff format python tests benchmarks

bench: install
	cargo bench --workspace
	. $(BIN)/activate && for b in benchmarks/*.py; do python $$b; done

check: install lint test

clean:
	rm -rf $(VENV) target out
