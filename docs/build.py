"""Build the documentation site: the one home of how it is built, for `make docs` and for
tests/test_docs_site.py (which builds into a temporary folder in make test).

    python docs/build.py [OUTPUT]      # default docs/_build/html

Warnings are errors (-W), all of them reported before failing (--keep-going), and every
cross-reference must resolve (-n, nitpicky): a broken link between pages, to a heading or
to an API object fails the build. The doctrees go beside the output, so a build into a
temporary folder writes nothing into docs/. Exit code: Sphinx's (0: built, no warning).
"""

from __future__ import annotations

import sys
from pathlib import Path

DOCS = Path(__file__).resolve().parent
OUTPUT = DOCS / "_build" / "html"


def arguments(output: Path) -> list[str]:
    """sphinx-build's arguments for a build of the site into `output`."""
    output = Path(output)
    return ["-W", "--keep-going", "-n", "-q", "-b", "html", "-d", str(output.parent / f"{output.name}.doctrees"),
            str(DOCS), str(output)]


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    from sphinx.cmd.build import build_main

    return build_main(arguments(Path(argv[0]) if argv else OUTPUT))


if __name__ == "__main__":
    sys.exit(main())
