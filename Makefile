# Every target creates .venv and installs the package (with its pinned dependencies) first.
PYTHON ?= python3
VENV := .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.installed-stamp
OUT ?= out
# Small dense products dominate our numerics; threaded OpenBLAS is measured 5-170x slower on
# tall-skinny products on a 2-core machine, and pytest already runs 2 workers.
export OPENBLAS_NUM_THREADS ?= 1
export OMP_NUM_THREADS ?= 1

# Exact versions of everything installed into .venv (pyproject.toml keeps the compatible ranges
# for library users); `make lock` refreshes it.
LOCK := constraints.txt

.PHONY: demo test bench reproduce report docs install lock clean wheel-check

$(STAMP): pyproject.toml setup.py $(LOCK) $(wildcard sobolev_drake/native/*.c sobolev_drake/native/*.h)
	test -x $(PY) || $(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet -c $(LOCK) --upgrade pip
	$(PY) -m pip install --quiet -c $(LOCK) -e '.[test,docs]'
	touch $(STAMP)

# Resolve the newest versions the pyproject ranges allow in a scratch venv and pin them all.
lock:
	rm -rf .venv-lock && $(PYTHON) -m venv .venv-lock
	.venv-lock/bin/pip install --quiet --upgrade pip
	.venv-lock/bin/pip install --quiet -e '.[test,docs]'
	{ sed -n '/^#/p' $(LOCK); .venv-lock/bin/pip freeze --all --exclude-editable \
	    | grep -v -E '^(setuptools|wheel)=='; } > $(LOCK).new
	mv $(LOCK).new $(LOCK) && rm -rf .venv-lock
	@echo "$(LOCK) refreshed; run 'make clean test' to install and test exactly these versions"

install: $(STAMP)

demo: $(STAMP)
	MPLBACKEND=Agg $(VENV)/bin/sobolev-drake demo --out $(OUT)

test: $(STAMP)
	MPLBACKEND=Agg $(PY) -m pytest -n 2 -q tests

bench: $(STAMP)
	@for b in benchmarks/*.py; do echo "== $$b"; MPLBACKEND=Agg $(PY) $$b || exit 1; done

# The documentation site into build/docs: guides, API reference, the gallery (fast diagrams/
# scripts executed), the tutorial notebook executed (offline; any warning, a module that fails
# to import or a failing example fails the build; docs/maintainers.md)
docs: $(STAMP)
	MPLBACKEND=Agg $(PY) -m sphinx -W --keep-going -q -b html docs build/docs
	@echo "documentation site: build/docs/index.html"

# $(OUT)/REPRODUCTION.md and the repository's docs/experiments/REPRODUCTION.md (links relative to each); a
# REPRODUCTION.md that sobolev-drake did not write is never replaced
reproduce: $(STAMP)
	MPLBACKEND=Agg $(VENV)/bin/sobolev-drake reproduce --out $(OUT) --copy-to docs/experiments/REPRODUCTION.md

# the same two files rebuilt from $(OUT)/*/result.json and $(OUT)/campaigns/ without rerunning
report: $(STAMP)
	MPLBACKEND=Agg $(VENV)/bin/sobolev-drake report --out $(OUT) --copy-to docs/experiments/REPRODUCTION.md

# the sdist and the wheel built, the wheel installed (constraints.txt versions) into a clean venv
# outside the repository and run from elsewhere, with and without a C compiler (.ci/wheel-check)
wheel-check:
	PYTHON=$(PYTHON) bash .ci/wheel-check

clean:
	rm -rf $(VENV) .venv-lock $(OUT) build *.egg-info sobolev_drake/native/*.so docs/gallery \
	    docs/sg_execution_times.rst docs/tutorial/_generated docs/tutorial/*.md
