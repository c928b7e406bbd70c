# The two commands of the README: `make demo` and `make test`.
# Both create .venv, install pendfmu (editable) with what it needs, build the FMUs, then run.

PYTHON ?= python3
VENV   := .venv
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.installed-stamp

.PHONY: demo test fmus tools clean

$(STAMP): pyproject.toml
	@$(PYTHON) -c 'import sys; sys.exit(sys.version_info < (3, 11))' || { echo "pendfmu needs Python >= 3.11: run make PYTHON=/path/to/python3.11" >&2; exit 2; }
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --disable-pip-version-check -e '.[test]'
	@touch $(STAMP)

fmus: $(STAMP)
	$(PY) -m pendfmu build

demo: fmus
	$(PY) -m pendfmu demo

test: fmus tools
	$(PY) -m pytest

# valgrind for the memcheck test (Debian's package; this kind of machine usually has it);
# libtbb12 for ecos (PyPI ecospy's libecosc.so links it), which runs the rig SSP in tests/test_ssp_tools.py
tools:
	@command -v valgrind >/dev/null 2>&1 || { apt-get update -qq && apt-get install -y -qq valgrind; } \
	  || echo "warning: valgrind could not be installed; the memcheck test will be skipped" >&2
	@ldconfig -p 2>/dev/null | grep -q 'libtbb\.so\.12' || { apt-get update -qq && apt-get install -y -qq libtbb12; } \
	  || echo "warning: libtbb12 could not be installed; the ecos tests will be skipped" >&2

clean:
	rm -rf $(VENV) fmus/*.fmu fmus/build out .pytest_cache
