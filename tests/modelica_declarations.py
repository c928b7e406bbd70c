"""Read the public declarations of a Modelica class file, for the interface test.

A small tokenizer, not a Modelica compiler: it reads the element declarations of one
class (`[final] [parameter|input|output] Type name(modifiers) = binding "description";`)
up to its first equation/algorithm section, which is all the interface test compares
with pendfmu/components.py. It is independent of rumoca on purpose: the interface
check should not depend on how one compiler flattens or classifies variables (rumoca,
for instance, turns a protected sub-component's outputs into model outputs and drops an
output that became a state).

Anything it does not understand raises ModelicaSyntaxError naming the file and the
offending text, so a library change that outgrows it fails loudly, never silently.
"""

from __future__ import annotations

import ast
import math
import operator
import re
from dataclasses import dataclass, field
from pathlib import Path

LIBRARY = Path(__file__).resolve().parents[1] / "modelica" / "PendulumID"

_TOKEN = re.compile(
    r"""
    (?P<space>\s+|//[^\n]*|/\*.*?\*/)
  | (?P<string>"(?:[^"\\]|\\.)*")
  | (?P<number>(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?)
  | (?P<name>[A-Za-z_][A-Za-z_0-9]*(?:\.[A-Za-z_][A-Za-z_0-9]*)*)
  | (?P<op><>|<=|>=|==|:=|[-+*/^(),;=<>\[\]{}:.])
    """,
    re.VERBOSE | re.DOTALL,
)
_SECTION_END = {"equation", "algorithm", "initial", "annotation", "end"}
_PREFIXES = {"final", "parameter", "constant", "discrete", "input", "output", "flow", "stream", "inner", "outer"}


class ModelicaSyntaxError(ValueError):
    """The file holds something this reader does not handle."""


@dataclass(frozen=True)
class Declaration:
    """One component declaration: prefixes, type, name, modifiers (text), binding, description."""

    name: str
    type: str
    prefixes: frozenset[str]
    modifiers: dict[str, str] = field(default_factory=dict)
    binding: str | None = None
    description: str = ""
    protected: bool = False

    @property
    def causality(self) -> str:
        for kind in ("parameter", "input", "output"):
            if kind in self.prefixes:
                return kind
        return "local"

    @property
    def unit(self) -> str:
        return _unquote(self.modifiers.get("unit", '""'))

    @property
    def start(self) -> float | None:
        """A parameter's default is its binding; any other variable's is its start attribute."""
        text = self.binding if self.causality == "parameter" else self.modifiers.get("start")
        return None if text is None else evaluate(text)


@dataclass(frozen=True)
class ModelicaClass:
    name: str
    description: str
    declarations: dict[str, Declaration]


def tokenize(text: str, where: str = "<text>") -> list[tuple[str, str]]:
    tokens, pos = [], 0
    while pos < len(text):
        match = _TOKEN.match(text, pos)
        if not match:
            raise ModelicaSyntaxError(f"{where}: cannot read {text[pos:pos + 30]!r}")
        pos = match.end()
        if match.lastgroup != "space":
            tokens.append((match.lastgroup, match.group()))
    return tokens


def _unquote(token: str) -> str:
    if not (token.startswith('"') and token.endswith('"')):
        raise ModelicaSyntaxError(f"expected a string literal, got {token!r}")
    return token[1:-1].replace('\\"', '"').replace("\\\\", "\\")


def _join(tokens: list[tuple[str, str]]) -> str:
    return " ".join(value for _, value in tokens)


def _split_top_level(tokens: list[tuple[str, str]], separator: str) -> list[list[tuple[str, str]]]:
    parts, current, depth = [], [], 0
    for token in tokens:
        if token[1] in "([{":
            depth += 1
        elif token[1] in ")]}":
            depth -= 1
        if depth == 0 and token[1] == separator:
            parts.append(current)
            current = []
        else:
            current.append(token)
    if current:
        parts.append(current)
    return parts


def _declaration(tokens: list[tuple[str, str]], protected: bool, where: str) -> Declaration:
    k, prefixes = 0, set()
    while k < len(tokens) and tokens[k][1] in _PREFIXES:
        prefixes.add(tokens[k][1])
        k += 1
    if k + 1 >= len(tokens) or tokens[k][0] != "name" or tokens[k + 1][0] != "name":
        raise ModelicaSyntaxError(f"{where}: not a declaration: {_join(tokens)!r}")
    type_name, name = tokens[k][1], tokens[k + 1][1]
    rest = tokens[k + 2:]
    if rest and rest[0][1] == "[":  # an array's dimensions (the Controller's shift registers): skipped
        close = next((i for i, t in enumerate(rest) if t[1] == "]"), None)
        if close is None:
            raise ModelicaSyntaxError(f"{where}: {name}: unclosed array dimensions")
        rest = rest[close + 1:]
    modifiers: dict[str, str] = {}
    if rest and rest[0][1] == "(":
        depth = 0
        for end, token in enumerate(rest):
            depth += token[1] == "("
            depth -= token[1] == ")"
            if depth == 0:
                break
        for part in _split_top_level(rest[1:end], ","):
            part = [t for t in part if t[1] not in ("final", "each")]
            if len(part) < 3 or part[1][1] != "=":
                raise ModelicaSyntaxError(f"{where}: {name}: cannot read modifier {_join(part)!r}")
            modifiers[part[0][1]] = _join(part[2:])
        rest = rest[end + 1:]
    # what is left: [= binding] [description strings] [annotation(...)]
    cut = next((i for i, t in enumerate(rest) if t[1] == "annotation"), len(rest))
    rest = rest[:cut]
    strings = 0
    while strings < len(rest) and rest[len(rest) - 1 - strings][0] == "string":
        strings += 1
    description_tokens = [t for t in rest[len(rest) - strings:] if t[1] != "+"]
    rest = rest[:len(rest) - strings]
    binding = None
    if rest:
        if rest[0][1] != "=":
            raise ModelicaSyntaxError(f"{where}: {name}: cannot read {_join(rest)!r}")
        binding = _join(rest[1:])
    description = "".join(_unquote(t[1]) for t in description_tokens)
    return Declaration(name, type_name, frozenset(prefixes), modifiers, binding, description, protected)


def parse_class(text: str, where: str = "<text>") -> ModelicaClass:
    """The declarations of the (single, top) class in `text`, a `within ...;` file."""
    tokens = tokenize(text, where)
    k = 0
    if tokens and tokens[0][1] == "within":
        k = next(i for i, t in enumerate(tokens) if t[1] == ";") + 1
    while k < len(tokens) and tokens[k][1] in {"partial", "encapsulated", "final"}:
        k += 1
    if k + 1 >= len(tokens) or tokens[k][1] not in {"model", "block", "class", "package"}:
        raise ModelicaSyntaxError(f"{where}: expected a class header")
    name = tokens[k + 1][1]
    k += 2
    description = ""
    while k < len(tokens) and tokens[k][0] == "string":
        description += _unquote(tokens[k][1])
        k += 1
    declarations: dict[str, Declaration] = {}
    protected, statement = False, []
    depth = 0
    while k < len(tokens):
        token = tokens[k]
        k += 1
        if depth == 0 and not statement and token[1] in _SECTION_END:
            break
        if depth == 0 and not statement and token[1] in {"protected", "public"}:
            protected = token[1] == "protected"
            continue
        depth += token[1] in "([{"
        depth -= token[1] in ")]}"
        if depth == 0 and token[1] == ";":
            if statement[0][1] in {"extends", "import"}:
                raise ModelicaSyntaxError(f"{where}: {statement[0][1]} is not handled by this reader")
            decl = _declaration(statement, protected, where)
            if decl.name in declarations:
                raise ModelicaSyntaxError(f"{where}: {decl.name} declared twice")
            declarations[decl.name] = decl
            statement = []
        else:
            statement.append(token)
    return ModelicaClass(name, description, declarations)


def read_class(name: str) -> ModelicaClass:
    """The class `name` of the library, from `PendulumID/<name>.mo`."""
    path = LIBRARY / f"{name}.mo"
    if not path.is_file():
        raise FileNotFoundError(f"no Modelica class file {path}")
    return parse_class(path.read_text(encoding="utf-8"), str(path))


_OPERATORS = {ast.Add: operator.add, ast.Sub: operator.sub, ast.Mult: operator.mul, ast.Div: operator.truediv,
              ast.Pow: operator.pow, ast.USub: operator.neg, ast.UAdd: operator.pos}
_CONSTANTS = {"pi": math.pi, "PendulumID.pi": math.pi, "true": 1.0, "false": 0.0}


def evaluate(text: str) -> float:
    """Value of a constant Modelica expression: numbers, pi, + - * / ^ and parentheses
    (true and false as 1 and 0: a Boolean parameter's default)."""
    for name, value in _CONSTANTS.items():
        text = re.sub(rf"(?<![\w.]){re.escape(name)}(?![\w.])", repr(value), text)
    try:
        tree = ast.parse(text.replace("^", "**"), mode="eval")
    except SyntaxError:
        raise ModelicaSyntaxError(f"not a constant expression: {text!r}") from None

    def value(node):
        if isinstance(node, ast.Expression):
            return value(node.body)
        if isinstance(node, ast.Constant) and isinstance(node.value, (int, float)):
            return float(node.value)
        if isinstance(node, ast.BinOp) and type(node.op) in _OPERATORS:
            return _OPERATORS[type(node.op)](value(node.left), value(node.right))
        if isinstance(node, ast.UnaryOp) and type(node.op) in _OPERATORS:
            return _OPERATORS[type(node.op)](value(node.operand))
        raise ModelicaSyntaxError(f"not a constant expression: {text!r}")

    return value(tree)
