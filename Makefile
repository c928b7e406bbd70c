# The two commands of the README: `make demo` and `make test`.
# Both create .venv, install pendfmu (editable) with what it needs, build the FMUs, then run.

PYTHON ?= python3
VENV   := .venv
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.installed-stamp

.PHONY: demo test acceptance docs fmus tools clean

$(STAMP): pyproject.toml
	@$(PYTHON) -c 'import sys; sys.exit(sys.version_info < (3, 11))' || { echo "pendfmu needs Python >= 3.11: run make PYTHON=/path/to/python3.11" >&2; exit 2; }
	$(PYTHON) -m venv $(VENV)
	@# uv (PyPI) installs the same packages in 15 s where pip took 90 on a fresh clone; pip if uv cannot
	$(PY) -m pip install --quiet --disable-pip-version-check uv && $(VENV)/bin/uv pip install --quiet --python $(PY) -e '.[test]' \
	  || $(PY) -m pip install --quiet --disable-pip-version-check -e '.[test]'
	@touch $(STAMP)

fmus: $(STAMP)
	$(PY) -m pendfmu build

demo: fmus
	$(PY) -m pendfmu demo

# The documentation site, into docs/_build/html: warnings are errors and every link and reference
# must resolve (docs/build.py, the one home of how it is built; make test builds it too, in
# tests/test_docs_site.py). Its reference pages are generated from the code at build time.
docs: $(STAMP)
	$(PY) docs/build.py

# Two pytest-xdist workers, a module whole on one (--dist loadfile; tests/conftest.py): the fits' own worker pools
# leave a core idle in their serial phases (local refinement, validation, subprocesses), which
# the other worker fills. --no-loadscope-reorder keeps conftest's order (the longest modules
# first): xdist's own puts the modules with the most tests first, and the docs' runner's tests,
# 6 minutes, ran alone at the end.
#
# Python may cache compiled modules (__pycache__, git-ignored) while the tests run, even where the
# environment says not to (PYTHONDONTWRITEBYTECODE, set on the project's machines): every
# `pendfmu` command and worker the tests start, and every pytest they start (the plugin's
# tests), would otherwise compile pendfmu anew, and pytest rewrite its modules anew; the docs'
# runner alone took 172 s instead of 162.
test: tools fmus
	PYTHONDONTWRITEBYTECODE= $(PY) -m pytest -n 2 --dist loadfile --no-loadscope-reorder -m "not acceptance"

# The runs marked acceptance (pytest.mark.acceptance in the test modules): the docs' walkthrough
# as written (bootstrap intervals), the real-data examples and fits whose single run takes
# minutes, and further cases of what make test checks once (a second law, a second basin, a
# second seed). Run before a release and after changing the fit's search, intervals or examples.
acceptance: tools fmus
	PYTHONDONTWRITEBYTECODE= $(PY) -m pytest -n 2 --dist loadfile --no-loadscope-reorder -m acceptance

# Debian's packages for tests: valgrind (memcheck), mingw-w64 (the FMUs' win64 DLLs) and wine
# (runs them, tests/test_win64.py), GNU Octave and unzip (the exported Simulink script),
# chromium (the report's browser test), libtbb12 (ecos, PyPI ecospy's libecosc.so links it)
tools:
	@command -v valgrind >/dev/null 2>&1 || { apt-get update -qq && apt-get install -y -qq valgrind; } \
	  || echo "warning: valgrind could not be installed; the memcheck test will be skipped" >&2
	@command -v x86_64-w64-mingw32-gcc >/dev/null 2>&1 || { apt-get update -qq && apt-get install -y -qq gcc-mingw-w64-x86-64; } \
	  || echo "warning: gcc-mingw-w64-x86-64 could not be installed; the FMUs get no win64 DLL and the Windows tests are skipped" >&2
	@{ command -v wine >/dev/null 2>&1 || command -v wine64 >/dev/null 2>&1; } || { apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq wine wine64; } \
	  || echo "warning: wine could not be installed; the tests that run the win64 DLLs are skipped" >&2
	@{ command -v octave-cli >/dev/null 2>&1 && command -v unzip >/dev/null 2>&1; } \
	  || { apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends octave unzip; } \
	  || echo "warning: GNU Octave could not be installed; the tests that run the exported MATLAB script will be skipped" >&2
	@command -v chromium >/dev/null 2>&1 || { apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq chromium; } \
	  || echo "warning: chromium could not be installed; the report's browser test will be skipped" >&2
	@ldconfig -p 2>/dev/null | grep -q 'libtbb\.so\.12' || { apt-get update -qq && apt-get install -y -qq libtbb12; } \
	  || echo "warning: libtbb12 could not be installed; the ecos tests will be skipped" >&2

clean:
	rm -rf $(VENV) fmus out .pytest_cache build dist docs/_build
