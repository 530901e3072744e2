"""Parse a .kyx archive (lark) and read its declarations; errors name file:line:column."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from lark import Lark, Tree
from lark.exceptions import UnexpectedCharacters, UnexpectedEOF, UnexpectedInput, UnexpectedToken

from certiloop.models.kyx.grammar import GRAMMAR
from certiloop.models.lang.terms import (
    ModelError,
)


class KyxError(ModelError):
    """A .kyx file is malformed or uses what certiloop does not support; names file:line:col."""


_PARSER: Lark | None = None
BUILTINS = ("abs", "min", "max")


def _parser() -> Lark:
    global _PARSER
    if _PARSER is None:
        # cache=True: lark keeps the LALR tables in the temp folder, keyed by the grammar's hash
        _PARSER = Lark(GRAMMAR, parser="lalr", propagate_positions=True, maybe_placeholders=False,
                       cache=True)
    return _PARSER


def place(source: str, node: Any) -> str:
    meta = getattr(node, "meta", None)
    line = getattr(node, "line", None) or getattr(meta, "line", None)
    column = getattr(node, "column", None) or getattr(meta, "column", None)
    return f"{source}:{line}:{column}" if line is not None else source


def _sort(token) -> str:
    """KeYmaera X 4 wrote R and B for Real and Bool."""
    return {"R": "Real", "B": "Bool"}.get(str(token), str(token))


# constructs KeYmaera X has and certiloop does not, named instead of "unexpected token"
_KNOWN = (("___", "an exercise blank `__________`: fill it in first"),
          ("^@", "hybrid games (`^@`, `--`) are not supported"),
          ("--", "hybrid games (`^@`, `--`) are not supported"),
          ("{|", "program symbols with space restrictions `a{|x|}` are not supported"),
          ("implicit", "implicit definitions are not supported"))


def parse_tree(text: str, source: str = "<kyx>") -> Tree:
    text = text.removeprefix("\ufeff")  # a byte-order mark some editors write
    try:
        return _parser().parse(text)
    except UnexpectedCharacters as exc:
        raise KyxError(f"{source}:{exc.line}:{exc.column}: unexpected character "
                       f"{text[exc.pos_in_stream]!r}") from None
    except UnexpectedToken as exc:
        if exc.token.type == "$END":
            raise KyxError(f"{source}: unexpected end of file (a missing `End.`?)") from None
        known = next((why for start, why in _KNOWN if str(exc.token.value).startswith(start)), None)
        if known is not None:
            raise KyxError(f"{source}:{exc.line}:{exc.column}: {known}") from None
        raise KyxError(f"{source}:{exc.line}:{exc.column}: unexpected {_first_word(exc.token.value)!r}"
                       f" (expected {_readable(exc.accepts or exc.expected)})") from None
    except UnexpectedEOF:
        raise KyxError(f"{source}: unexpected end of file (a missing `End.`?)") from None
    except UnexpectedInput as exc:  # pragma: no cover - the three above are all lark raises
        raise KyxError(f"{source}:{exc.line}:{exc.column}: cannot parse here") from None


def _first_word(text: str) -> str:
    words = str(text).split()
    return words[0][:30] if words else str(text)[:30]


def _readable(names) -> str:
    """Terminal names as what to type: `;`, `End.`, a number, ..."""
    shown = set()
    for name in names:
        term = next((t for t in _parser().terminals if t.name == name), None)
        if name in ("IDENT", "DIFFSYM", "NUMBER", "STRING", "CMP", "ADDOP", "MULOP"):
            shown.add({"IDENT": "a name", "DIFFSYM": "x'", "NUMBER": "a number", "STRING": "a string",
                       "CMP": "a comparison", "ADDOP": "+ or -", "MULOP": "* or /"}[name])
        elif term is not None and term.pattern.type == "str":
            shown.add(f"`{term.pattern.value}`")
        elif name == "END":
            shown.add("`End.`")
    return "one of " + ", ".join(sorted(shown)) if shown else "something else"


# --------------------------------------------------------------------------- declarations


@dataclass
class Definition:
    kind: str  # constant | term | formula | program
    params: tuple[str, ...] = ()
    body: Tree | None = None
    where: Any = None


@dataclass
class Scope:
    source: str
    defs: dict[str, Definition] = field(default_factory=dict)
    variables: list[str] = field(default_factory=list)
    bools: set[str] = field(default_factory=set)

    def declare(self, name: str, d: Definition) -> None:
        if name in self.defs or name in self.variables:
            raise KyxError(f"{place(self.source, d.where)}: `{name}` is declared twice")
        self.defs[name] = d


def declarations(items: list[Tree], scope: Scope) -> None:
    for block in items:
        if block.data == "variables":
            for decl in block.children:
                if not isinstance(decl, Tree):
                    continue
                sort, *names = decl.children
                for n in names:
                    if _sort(sort) != "Real":
                        raise KyxError(f"{place(scope.source, n)}: program variable `{n}` of sort "
                                       f"{sort}: only Real program variables are supported")
                    if n in scope.defs or n in scope.variables:
                        raise KyxError(f"{place(scope.source, n)}: `{n}` is declared twice")
                    scope.variables.append(str(n))
        elif block.data in ("definitions", "shared"):
            for decl in block.children:
                if isinstance(decl, Tree):
                    _declaration(decl, scope)


def _params(tree: Tree | None, scope: Scope) -> tuple[str, ...]:
    if tree is None:
        return ()
    out = []
    for p in tree.children:
        sort, *name = p.children
        if _sort(sort) != "Real" or not name:
            raise KyxError(f"{place(scope.source, sort)}: function parameters must be named Real "
                           "parameters, as in `Real f(Real x) = x^2;`")
        out.append(str(name[0]))
    return tuple(out)


def _declaration(decl: Tree, scope: Scope) -> None:
    kind = decl.data
    if kind == "import_":
        path = ".".join(str(c) for c in decl.children)
        if not all(str(c) in ("kyx", "math", *BUILTINS) for c in decl.children):
            raise KyxError(f"{place(scope.source, decl)}: import {path} is not supported (only "
                           "kyx.math.abs, min and max)")
        return
    if kind == "decl_names":
        sort, *names = decl.children
        for n in names:
            scope.declare(str(n), Definition("constant", where=n))
            if _sort(sort) == "Bool":
                scope.bools.add(str(n))
        return
    if kind == "decl_function":
        sort, name, *rest = decl.children
        if str(name) in BUILTINS and rest:  # KeYmaera X 4 declared `R abs(R).`: ours is built in
            return
        if rest and rest[0].children:
            raise KyxError(f"{place(scope.source, name)}: uninterpreted function `{name}` with "
                           "arguments is not supported: give it a definition (`= ...`)")
        scope.declare(str(name), Definition("constant", where=name))
        if _sort(sort) == "Bool":
            scope.bools.add(str(name))
        return
    if kind in ("def_term", "def_formula"):
        sort, name, *rest = decl.children
        body = rest[-1]
        params = _params(rest[0] if len(rest) == 2 else None, scope)
        want = "Real" if kind == "def_term" else "Bool"
        if _sort(sort) != want:
            raise KyxError(f"{place(scope.source, name)}: `{name}` is declared {sort} but defined "
                           f"with {'=' if want == 'Real' else '<->'}")
        scope.declare(str(name), Definition("term" if want == "Real" else "formula", params, body, name))
        return
    if kind == "decl_program":
        raise KyxError(f"{place(scope.source, decl.children[0])}: program constant "
                       f"`{decl.children[0]}` without a definition is not supported")
    if kind == "def_program":
        name, body = decl.children
        scope.declare(str(name), Definition("program", (), body, name))
        return
    raise KyxError(f"{place(scope.source, decl)}: unsupported declaration")  # pragma: no cover
