# jostle: `make demo` runs the embedded default; `make test` runs the checks. Both set up first.
VENV := .venv
BIN := $(VENV)/bin

.PHONY: setup demo test lint typecheck bench clean help

help:
	@echo "make demo   set up, then replay the shipped recording headless into out/demo/"
	@echo "make test   set up, then run ruff, mypy and pytest"
	@echo "make bench  set up, then run the benchmarks (slow)"

setup:
	@scripts/setup.sh

demo: setup
	$(BIN)/jostle run configs/demo.toml --headless --out out/demo

lint: setup
	$(BIN)/ruff check .

typecheck: setup
	$(BIN)/mypy

test: setup
	$(BIN)/ruff check .
	$(BIN)/mypy
	$(BIN)/python -m pytest -q

bench: setup
	$(BIN)/python -m pytest -q -m slow

clean:
	rm -rf out .pytest_cache .mypy_cache .ruff_cache
