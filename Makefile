# Two commands on a fresh machine:  `make demo`  and  `make test`.
# Both create .venv from pyproject.toml when it is missing or older than
# pyproject.toml, install the Debian libraries off-screen rendering needs
# (if missing), then run.
PYTHON ?= python3
VENV   := .venv
STAMP  := $(VENV)/.installed-stamp
OUT    ?= studies/results

.PHONY: demo test test-crosscheck gallery studies bench bench-elastica system-deps clean-venv

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(VENV)/bin/python -m pip install --quiet --upgrade pip
	$(VENV)/bin/python -m pip install --quiet -e '.[test,dask]'
	@sh scripts/system-deps.sh
	$(VENV)/bin/python -m pip install --quiet -e '.[cholmod]' || \
		echo "knitfem: scikit-sparse (CHOLMOD) did not build; sparse Cholesky uses QDLDL"
	touch $(STAMP)

system-deps:
	@sh scripts/system-deps.sh

demo: $(STAMP) system-deps
	$(VENV)/bin/python studies/popup_fig4a.py --out $(OUT)/popup_fig4a

test: $(STAMP) system-deps
	$(VENV)/bin/python -m pytest -q -n auto --dist loadfile

# issue 12's cross-model check (both models on a 10 x 10 swatch, ~15 min)
test-crosscheck: $(STAMP) system-deps
	$(VENV)/bin/python -m pytest -q --crosscheck tests/test_crosscheck.py

gallery: $(STAMP) system-deps
	$(VENV)/bin/knitfem gallery --out $(OUT)/gallery

studies: $(STAMP) system-deps
	$(VENV)/bin/python studies/popup_fig4a.py --out $(OUT)/popup_fig4a
	$(VENV)/bin/python studies/popup_heatmap.py --out $(OUT)/popup_heatmap
	$(VENV)/bin/python studies/popup_convergence.py --out $(OUT)/popup_convergence
	$(VENV)/bin/python studies/crosscheck_popup.py --out $(OUT)/crosscheck_popup
	$(VENV)/bin/python studies/knit_swatch.py --out $(OUT)/knit_swatch
	$(VENV)/bin/knitfem gallery --out $(OUT)/gallery --quiet

bench: $(STAMP)
	$(VENV)/bin/python studies/bench_beam.py --out $(OUT)/bench_beam
	$(VENV)/bin/python studies/bench_popup.py --out $(OUT)/bench_popup
	$(VENV)/bin/python studies/bench_contact.py --out $(OUT)/bench_contact
	$(VENV)/bin/python studies/bench_fabric_phase.py --out $(OUT)/fabric_phase_bench

# optional: knitfem vs PyElastica on the S-rod (the `elastica` extra, in its own venv so
# that PyElastica's pins never touch the main one)
bench-elastica: $(STAMP)
	test -x .venv-elastica/bin/python || $(PYTHON) -m venv .venv-elastica
	.venv-elastica/bin/python -m pip install --quiet -e '.[elastica]'
	NUMBA_CACHE_DIR=.numba-elastica .venv-elastica/bin/python studies/bench_pyelastica.py \
		--out $(OUT)/bench_pyelastica

clean-venv:
	rm -rf $(VENV)
