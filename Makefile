# Two commands do all the set-up on a fresh Debian machine (as root):
#   make demo   render the built-in demo scene to out/demo.png
#   make test   run the test suite
PYTHON ?= python3
VENV   ?= .venv
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.installed
# Test workers (pytest-xdist): one per core, at most four; PYTEST_WORKERS=0 runs in one process. Each test
# module goes whole to one worker (--dist loadscope: its module fixtures are built once), the modules
# that took longest last time first (tests/conftest.py).
PYTEST_WORKERS ?= auto

.PHONY: demo test bench setup sysdeps clean docs gallery gpu-suite

demo: $(STAMP)
	@mkdir -p out
	$(VENV)/bin/caustica render caustic-sphere -o out/demo.png --explain

test: $(STAMP)
	$(PY) -m pytest -n $(PYTEST_WORKERS) --maxprocesses=4 --dist loadscope $(PYTEST_ARGS)

# The docs site (mkdocs.yml) into site/; --strict: any warning (a broken link, an unreadable docstring) fails.
docs: $(STAMP)
	@$(PY) -c "import mkdocs, mkdocstrings, mkdocstrings_handlers.python" 2>/dev/null || $(PY) -m pip install -q -e '.[docs]'
	$(PY) -m mkdocs build --strict -d site

gallery: $(STAMP)
	$(PY) scripts/make_gallery.py

gpu-suite:
	bash bench/gpu_suite.sh

bench: $(STAMP)
	$(PY) bench/bench_presets.py

setup: $(STAMP)

sysdeps:
	@sh scripts/install-sysdeps.sh

$(STAMP): pyproject.toml scripts/install-sysdeps.sh
	@sh scripts/install-sysdeps.sh
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install -q --upgrade pip
	$(PY) -m pip install -q -e '.[test,metrics,reference,plots,viewer,batch,docs]'
	@touch $(STAMP)

clean:
	rm -rf $(VENV) out .pytest_cache
