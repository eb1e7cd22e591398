# Two commands on a fresh machine:  `make demo`  and  `make test`.
# Both create .venv from pyproject.toml when it is missing or older than
# pyproject.toml, install the Debian libraries off-screen rendering needs
# (if missing), then run.
PYTHON ?= python3
VENV   := .venv
STAMP  := $(VENV)/.installed-stamp
OUT    ?= studies/results

.PHONY: demo test bench system-deps clean-venv

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(VENV)/bin/python -m pip install --quiet --upgrade pip
	$(VENV)/bin/python -m pip install --quiet -e '.[test]'
	touch $(STAMP)

system-deps:
	@sh scripts/system-deps.sh

demo: $(STAMP) system-deps
	$(VENV)/bin/knitfem gallery --out $(OUT)/gallery

test: $(STAMP) system-deps
	$(VENV)/bin/python -m pytest -q

bench: $(STAMP)
	$(VENV)/bin/python studies/bench_beam.py --out $(OUT)/bench_beam

clean-venv:
	rm -rf $(VENV)
