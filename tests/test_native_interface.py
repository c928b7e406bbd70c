"""The native loop's interface is declared once in C (pendfmu/csrc/runner/runner.h) and mirrored
with ctypes (pendfmu/simulator/native.py): the two must agree on every constant and on
the place of every field, or the loop reads garbage without a word."""

from __future__ import annotations

import ctypes
import os
import re
import subprocess

from pendfmu.fmubuild.compiler import FMI_HEADERS, SOURCE_DIR
from pendfmu.simulator import native

HEADER = SOURCE_DIR / "runner" / "runner.h"
STRUCTURES = (native.Unit, native.SystemUnit, native.Link, native.Drive, native.System)


def test_the_failure_kinds_are_the_headers():
    enum = re.search(r"enum FailKind \{(.*?)\};", HEADER.read_text(), re.S).group(1)
    declared = {name: int(value) for name, value in re.findall(r"\bFAIL_(\w+)\s*=\s*(\d+)", enum)}
    assert declared == {kind.name: kind.value for kind in native.Failure}


def test_max_ports_is_the_headers():
    (value,) = re.findall(r"^#define MAX_PORTS (\d+)$", HEADER.read_text(), re.M)
    assert int(value) == native.MAX_PORTS


def test_every_field_lies_where_the_header_puts_it(tmp_path):
    prints = [f'printf("{s.__name__} %zu\\n", sizeof({s.__name__}));' for s in STRUCTURES]
    prints += [f'printf("{s.__name__}.{name} %zu\\n", offsetof({s.__name__}, {name}));'
               for s in STRUCTURES for name, _ in s._fields_]
    source = tmp_path / "layout.c"
    source.write_text('#include <stdio.h>\n#include "runner.h"\nint main(void) {\n    '
                      + "\n    ".join(prints) + "\n    return 0;\n}\n")
    program = tmp_path / "layout"
    subprocess.run([os.environ.get("CC", "gcc"), "-std=c99", "-Wall", "-Werror", "-I", str(HEADER.parent),
                    "-I", str(FMI_HEADERS), str(source), "-o", str(program)], check=True)
    in_c = dict(line.split() for line in subprocess.run([str(program)], capture_output=True, text=True,
                                                        check=True).stdout.splitlines())
    in_python = {s.__name__: str(ctypes.sizeof(s)) for s in STRUCTURES}
    in_python |= {f"{s.__name__}.{name}": str(getattr(s, name).offset) for s in STRUCTURES for name, _ in s._fields_}
    assert in_python == in_c
