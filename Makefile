# pendtrack: the commands a newcomer needs are `make demo` and `make test`.
PYTHON ?= python3
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed
SAMPLE ?= sample_videos/12na1.mp4
DEMO_OUT ?= results/12na1
PYTEST_ARGS ?=
# One pytest worker per core (pytest-xdist), a test file per worker at a time: most tests run one process, and
# the default suite ran 15.0 min with one worker against 11.6 with two on 2 cores. XDIST= runs in this process.
XDIST ?= -n auto --dist loadfile

.PHONY: setup demo test test-unit test-slow test-all bench clean

setup: $(STAMP)

# The environment is built from PyPI only: nothing installed by hand is relied on.
$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e '.[test,dask]'
	$(BIN)/python -c "from pendtrack.models.kernels import compile_kernels; compile_kernels()"
	touch $@

demo: setup
	$(BIN)/pendtrack run $(SAMPLE) --out $(DEMO_OUT)
	@echo "report: $(DEMO_OUT)/report.html (open it in a browser)"

# The default suite (under 15 minutes on 2 cores); tests marked `slow` run in test-slow.
test: setup
	$(BIN)/python -m pytest -m "not slow" $(XDIST) $(PYTEST_ARGS)

# The unit loop (under 2 minutes on 2 cores): the core maths, without videos, stages, the CLI or subprocesses.
test-unit: setup
	$(BIN)/python -m pytest -m "not slow and not video and not integration" $(PYTEST_ARGS)

test-slow: setup
	$(BIN)/python -m pytest -m slow $(XDIST) $(PYTEST_ARGS)

test-all: setup
	$(BIN)/python -m pytest $(XDIST) $(PYTEST_ARGS)

bench: setup
	@for b in benchmarks/bench_*.py; do [ $$b = benchmarks/bench_coverage.py ] && continue; echo "== $$b"; $(BIN)/python $$b || exit 1; done

clean:
	rm -rf $(VENV) results .pytest_cache build *.egg-info
