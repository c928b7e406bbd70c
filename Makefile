# The two commands of the README: `make demo` and `make test`.
# Both create .venv, install pendfmu (editable) with what it needs, build the FMUs, then run.

PYTHON ?= python3
VENV   := .venv
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.installed-stamp

.PHONY: demo test fmus clean

$(STAMP): pyproject.toml
	@$(PYTHON) -c 'import sys; sys.exit(sys.version_info < (3, 11))' || { echo "pendfmu needs Python >= 3.11: run make PYTHON=/path/to/python3.11" >&2; exit 2; }
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --disable-pip-version-check -e '.[test]'
	@touch $(STAMP)

fmus: $(STAMP)
	$(PY) -m pendfmu build

demo: fmus
	$(PY) -m pendfmu demo

test: fmus
	$(PY) -m pytest

clean:
	rm -rf $(VENV) fmus/*.fmu fmus/build out .pytest_cache
