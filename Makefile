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

.PHONY: demo test bench reproduce install clean

$(STAMP): pyproject.toml setup.py $(wildcard sobolev_drake/native/*.c sobolev_drake/native/*.h)
	test -x $(PY) || $(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -e '.[test]'
	touch $(STAMP)

install: $(STAMP)

demo: $(STAMP)
	MPLBACKEND=Agg $(VENV)/bin/sobolev-drake demo --out $(OUT)

test: $(STAMP)
	MPLBACKEND=Agg $(PY) -m pytest -n 2 -q tests

bench: $(STAMP)
	@for b in benchmarks/*.py; do echo "== $$b"; MPLBACKEND=Agg $(PY) $$b || exit 1; done

reproduce: $(STAMP)
	MPLBACKEND=Agg $(VENV)/bin/sobolev-drake reproduce --out $(OUT)

clean:
	rm -rf $(VENV) $(OUT) build *.egg-info sobolev_drake/native/*.so
