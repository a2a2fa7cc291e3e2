# jostle: `make demo` runs the embedded default; `make test` runs the checks. Both set up first.
VENV := .venv
BIN := $(VENV)/bin

.PHONY: setup demo test lint typecheck bench clean help

help:
	@echo "make demo   set up, then replay the shipped recording headless into out/demo/"
	@echo "make test   set up, then run ruff, mypy and pytest"
	@echo "make bench  set up, then run the benchmarks (slow)"
	@echo "make lock   record the installed versions in constraints.txt (what setup installs)"

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

# constraints.txt: the versions setup installs. To move to newer releases: `.venv/bin/pip install -U -e '.[dev]'`,
# then `make test`, then `make lock` to record what passed.
.PHONY: lock
lock:
	{ sed -n '1,3p' constraints.txt; $(BIN)/python -m pip freeze --exclude-editable; } > constraints.txt.new
	mv constraints.txt.new constraints.txt

# Small synthetic recordings (webcam, OAK depth, pads, ground truth) that tests replay; rebuilt by the
# command itself (tests/test_performer_fixtures.py checks the committed ones are what it builds).
FIXTURE_SENSORS := --sensors webcam,oak,pads --truth --duration 6.5 --empty 1 --fps 10 --size 160x120 \
	--depth-size 160x100 --depth-fps 10 --no-depth-color --jpeg-quality 80

.PHONY: fixtures
fixtures: setup
	$(BIN)/jostle synth performer --people 2 --seed 0 $(FIXTURE_SENSORS) --out tests/fixtures/crossing2.mcap
	$(BIN)/jostle synth performer --people 3 --seed 1 --person-clips walk --person-clips walk+punch \
		--person-clips walk $(FIXTURE_SENSORS) --out tests/fixtures/group3.mcap
