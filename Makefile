# Two commands do all the set-up on a fresh Debian machine (as root):
#   make demo   render the built-in demo scene to out/demo.png
#   make test   run the test suite
PYTHON ?= python3
VENV   ?= .venv
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.installed

.PHONY: demo test bench setup sysdeps clean

demo: $(STAMP)
	@mkdir -p out
	$(VENV)/bin/caustica render caustic-sphere -o out/demo.png --explain

test: $(STAMP)
	$(PY) -m pytest $(PYTEST_ARGS)

bench: $(STAMP)
	$(PY) bench/bench_presets.py

setup: $(STAMP)

sysdeps:
	@sh scripts/install-sysdeps.sh

$(STAMP): pyproject.toml scripts/install-sysdeps.sh
	@sh scripts/install-sysdeps.sh
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install -q --upgrade pip
	$(PY) -m pip install -q -e '.[test,metrics,reference,plots,viewer,batch]'
	@touch $(STAMP)

clean:
	rm -rf $(VENV) out .pytest_cache
