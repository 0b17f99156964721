"""From source text to statements: the comment-stripping splitter and the Lark parse.

The source is cut into logical statements — a line, or a `{ ... }` bundle spanning lines — and
each is parsed with `grammar.lark` on its own. That makes error recovery trivial (one bad line
never hides the errors of the next) and lets the assembler skip statements inside a false
`.if` without parsing them, as a C preprocessor would.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from functools import lru_cache
from importlib import resources
from typing import Any

from lark import Lark, Token, Transformer, v_args
from lark.exceptions import UnexpectedCharacters, UnexpectedEOF, UnexpectedInput, UnexpectedToken

from netsushisen.isa.errors import Diagnostic

# --------------------------------------------------------------------------------------------
# Statement model


@dataclass(frozen=True)
class Expansion:
    """Where a line inside a `.macro` or `.rept` body was expanded: the invocation (or `.rept`)
    statement, itself possibly inside another expansion. Errors in the body name both places."""

    kind: str  # "macro" or "rept"
    name: str  # the macro's name ("" for .rept)
    at: "Loc"  # the invoking statement
    index: int = 0  # .rept: which repetition, from 1


@dataclass(frozen=True)
class Loc:
    file: str
    line: int
    col: int
    via: Expansion | None = None


@dataclass
class OperandAst:
    kind: str  # "expr" or "mem"
    expr: Any
    loc: Loc


@dataclass
class Instr:
    mnemonic: str
    operands: list[OperandAst]
    loc: Loc


@dataclass
class DirArg:
    kind: str  # "expr", "string", "assign"
    value: Any  # expression tree, str, or (name, expression)
    loc: Loc


@dataclass
class Directive:
    name: str  # without the dot
    args: list[DirArg]
    loc: Loc


@dataclass
class Bundle:
    instrs: list[Instr]
    loc: Loc


@dataclass
class Statement:
    labels: list[tuple[str, Loc]]
    item: Directive | Bundle | Instr | None
    loc: Loc
    source_lines: list[str] = field(default_factory=list)


@dataclass
class Chunk:
    """One logical statement's text (comments removed, columns kept) and where it came from."""

    text: str
    file: str
    line: int  # first line, 1-based
    source_lines: list[str]
    via: Expansion | None = None  # set on the lines of a macro or .rept expansion

    def source_line(self, line: int) -> str:
        i = line - self.line
        return self.source_lines[i] if 0 <= i < len(self.source_lines) else ""


# --------------------------------------------------------------------------------------------
# Splitting


def _outside_strings(line: str):
    """(index, character) of every character of a line outside string literals."""
    in_string = False
    i = 0
    while i < len(line):
        c = line[i]
        if in_string:
            if c == "\\":
                i += 1
            elif c == '"':
                in_string = False
        elif c == '"':
            in_string = True
        else:
            yield i, c
        i += 1


def _code_part(line: str) -> str:
    """The line without its comment (`#` or `//` to end of line, outside strings)."""
    for i, c in _outside_strings(line):
        if c == "#" or (c == "/" and line.startswith("//", i)):
            return line[:i]
    return line


def _brace_positions(code: str) -> list[tuple[int, str]]:
    return [(i, c) for i, c in _outside_strings(code) if c in "{}"]


def split_statements(text: str, file: str) -> tuple[list[Chunk], list[Diagnostic]]:
    """Cut source text into logical statements; report bundles that are never closed."""
    chunks: list[Chunk] = []
    errors: list[Diagnostic] = []
    lines = text.split("\n")
    open_chunk: list[str] | None = None
    open_src: list[str] = []
    open_at = (0, 0)
    for n, raw in enumerate(lines, start=1):
        code = _code_part(raw.rstrip("\r"))
        braces = _brace_positions(code)
        if open_chunk is None:
            if not code.strip():
                continue
            opens = [p for p, c in braces if c == "{"]
            closes = [p for p, c in braces if c == "}"]
            if opens and not [p for p in closes if p > opens[0]]:
                open_chunk, open_src, open_at = [code], [raw], (n, opens[0] + 1)
                continue
            chunks.append(Chunk(code, file, n, [raw]))
        else:
            if any(c == "{" for _, c in braces):
                pos = next(p for p, c in braces if c == "{")
                errors.append(Diagnostic(
                    "unterminated bundle: '{' is never closed before the next '{'",
                    file, open_at[0], open_at[1], lines[open_at[0] - 1]))
                open_chunk = None
                opens_after = [p for p, c in braces if c == "{"]
                closes_after = [p for p, c in braces if c == "}" and p > pos]
                if closes_after:
                    chunks.append(Chunk(code, file, n, [raw]))
                else:
                    open_chunk, open_src, open_at = [code], [raw], (n, opens_after[0] + 1)
                continue
            open_chunk.append(code)
            open_src.append(raw)
            if any(c == "}" for _, c in braces):
                chunks.append(Chunk("\n".join(open_chunk), file, open_at[0], open_src))
                open_chunk = None
    if open_chunk is not None:
        errors.append(Diagnostic("unterminated bundle: '{' is never closed",
                                 file, open_at[0], open_at[1], lines[open_at[0] - 1]))
    return chunks, errors


CONDITIONAL_RE = re.compile(r"^\s*(?:[A-Za-z_]\w*\s*:\s*)*\.(if|ifdef|ifndef|elif|else|endif)\b")


# --------------------------------------------------------------------------------------------
# Parsing


@lru_cache(maxsize=1)
def _lark() -> Lark:
    grammar = resources.files("netsushisen.asm").joinpath("grammar.lark").read_text()
    return Lark(grammar, parser="lalr", propagate_positions=True, maybe_placeholders=False,
                start=["start", "macro_header"])


def parse_macro_header(text: str) -> tuple[str, list[tuple[str, str | None, int]]] | tuple[str, int]:
    """The rest of a `.macro` line: (name, [(param, default or None, column)]), or on a syntax
    error (message, column) — columns 1-based within `text`."""
    try:
        tree = _lark().parse(text, start="macro_header")
    except UnexpectedInput as err:
        col = getattr(err, "column", 1) or 1
        if isinstance(err, UnexpectedCharacters):
            return f"unexpected character {text[col - 1:col]!r}", col
        tok = getattr(err, "token", None)
        if tok is None or tok.type == "$END":
            return "the line ends too early", len(text.rstrip()) + 1
        return f"unexpected {str(tok)!r}", col
    params = []
    for p in tree.children[1:]:
        name, default = p.children[0], (p.children[1] if len(p.children) > 1 else None)
        params.append((str(name), None if default is None else str(default).strip(), name.column))
    return str(tree.children[0]), params


_TOKEN_NAMES = {
    "NAME": "a name", "INT": "an integer", "FLOAT": "a number", "STRING": "a string",
    "DIRECTIVE": "a directive", "_NL": "end of line", "$END": "end of line",
    "COMMA": "','", "COLON": "':'", "LSQB": "'['", "RSQB": "']'", "LBRACE": "'{'",
    "RBRACE": "'}'", "LPAR": "'('", "RPAR": "')'", "SEMICOLON": "';'",
}


def _describe_expected(expected: set[str]) -> str:
    names = sorted({_TOKEN_NAMES.get(e, None) or f"'{e}'" for e in expected
                    if e in _TOKEN_NAMES})
    return ", ".join(names[:6])


class _ToAst(Transformer):
    def __init__(self, chunk: Chunk):
        super().__init__()
        self.chunk = chunk

    def _loc(self, meta_or_token) -> Loc:
        line = getattr(meta_or_token, "line", 1) or 1
        col = getattr(meta_or_token, "column", 1) or 1
        return Loc(self.chunk.file, self.chunk.line + line - 1, col, self.chunk.via)

    # expressions: nested tuples
    def int(self, items):
        t: Token = items[0]
        return ("int", int(t.replace("_", ""), 0) if not t.isdigit() else int(t), self._loc(t))

    def float(self, items):
        return ("float", float(items[0]), self._loc(items[0]))

    def name(self, items):
        t: Token = items[0]
        return ("name", str(t), self._loc(t))

    @v_args(meta=True)
    def call(self, meta, items):
        return ("call", str(items[0]), [i for i in items[1:] if i is not None], self._loc(meta))

    @v_args(meta=True)
    def neg(self, meta, items):
        return ("un", "-", items[0], self._loc(meta))

    @v_args(meta=True)
    def inv(self, meta, items):
        return ("un", "~", items[0], self._loc(meta))

    @v_args(meta=True)
    def lnot(self, meta, items):
        return ("un", "!", items[0], self._loc(meta))

    def __default__(self, data, children, meta):
        if isinstance(data, str) and data.startswith("op_"):
            return ("bin", data[3:], children[0], children[1])
        return super().__default__(data, children, meta)

    # statements
    @v_args(meta=True)
    def memref(self, meta, items):
        return OperandAst("mem", items[0], self._loc(meta))

    @v_args(meta=True)
    def instruction(self, meta, items):
        ops = []
        for it in items[1:]:
            if it is None:
                continue
            if isinstance(it, OperandAst):
                ops.append(it)
            else:
                ops.append(OperandAst("expr", it, _expr_loc(it) or self._loc(meta)))
        return Instr(str(items[0]), ops, self._loc(items[0]))

    @v_args(meta=True)
    def bundle(self, meta, items):
        return Bundle([i for i in items if isinstance(i, Instr)], self._loc(meta))

    @v_args(meta=True)
    def string(self, meta, items):
        raw = str(items[0])[1:-1]
        value = re.sub(r"\\(.)", r"\1", raw)
        return DirArg("string", value, self._loc(meta))

    @v_args(meta=True)
    def assign(self, meta, items):
        return DirArg("assign", (str(items[0]), items[1]), self._loc(items[0]))

    @v_args(meta=True)
    def directive(self, meta, items):
        args = []
        for it in items[1:]:
            if it is None:
                continue
            args.append(it if isinstance(it, DirArg) else
                        DirArg("expr", it, _expr_loc(it) or self._loc(meta)))
        return Directive(str(items[0])[1:], args, self._loc(items[0]))

    def label(self, items):
        return ("label", str(items[0]), self._loc(items[0]))

    def start(self, items):
        labels = [(i[1], i[2]) for i in items if isinstance(i, tuple) and i[0] == "label"]
        rest = [i for i in items if not (isinstance(i, tuple) and i[0] == "label")]
        return labels, (rest[0] if rest else None)


def _expr_loc(expr) -> Loc | None:
    """Where an expression starts: its unary operator or its leftmost operand."""
    if not isinstance(expr, tuple):
        return None
    if expr[0] in ("int", "float", "name"):
        return expr[2]
    if expr[0] in ("call", "un"):
        return expr[3]
    return _expr_loc(expr[2])  # ("bin", op, left, right)


def _depth(tree, stop: int) -> int:
    """The depth of a Lark tree, walked without recursion (stops counting past `stop`)."""
    deepest, todo = 0, [(tree, 1)]
    while todo:
        node, d = todo.pop()
        deepest = max(deepest, d)
        if deepest > stop:
            break
        todo.extend((child, d + 1) for child in getattr(node, "children", ()))
    return deepest


@lru_cache(maxsize=1 << 15)
def _parse_text(text: str):
    """Lark's tree of one statement's text. A render assembles the same kernels again and again
    (every scene, every test), and a macro body is the same text at each expansion, so the trees
    are kept by text; `_ToAst` builds new objects from a tree and never changes it."""
    return _lark().parse(text, start="start")


_SIMPLE = re.compile(r"[ \t]*(?:(?P<name>[A-Za-z_][A-Za-z0-9_]*)|(?P<int>(?:0|[1-9][0-9]*)(?![A-Za-z0-9_.]))"
                     r"|(?P<punct>[{};,:\[\]+-]))")


def _simple_statement(chunk: Chunk) -> Statement | None:
    """The statement of a one-line text made only of labels, names, decimal integers (negated
    too), `[base]`, `[base + offset]` and `{ ... ; ... }` — what the disassembler writes, so
    what a statistics file's listing holds (`asm.bounds.program_from_listing`) — as the Lark
    parse would give it (tests/test_parser.py compares the two); None for anything else, which
    Lark parses. Lark takes about a millisecond a statement; this a few microseconds."""
    text = chunk.text
    if "\n" in text:
        return None
    toks: list[tuple[str, str, int]] = []  # (kind, text, column)
    pos, end = 0, len(text.rstrip())
    while pos < end:
        m = _SIMPLE.match(text, pos)
        if m is None:
            return None
        kind = m.lastgroup
        toks.append((kind, m.group(kind), m.start(kind) + 1))
        pos = m.end()
    file, line, via = chunk.file, chunk.line, chunk.via

    def loc(col: int) -> Loc:
        return Loc(file, line, col, via)

    i = 0

    def at(kind: str, value: str | None = None) -> bool:
        return i < len(toks) and toks[i][0] == kind and (value is None or toks[i][1] == value)

    labels = []
    while at("name") and i + 1 < len(toks) and toks[i + 1][1] == ":":
        labels.append((toks[i][1], loc(toks[i][2])))
        i += 2

    def operand():
        nonlocal i
        if at("name"):
            i += 1
            e = ("name", toks[i - 1][1], loc(toks[i - 1][2]))
            return OperandAst("expr", e, e[2])
        if at("int"):
            i += 1
            e = ("int", int(toks[i - 1][1]), loc(toks[i - 1][2]))
            return OperandAst("expr", e, e[2])
        if at("punct", "-") and i + 1 < len(toks) and toks[i + 1][0] == "int":
            minus = loc(toks[i][2])
            i += 2
            return OperandAst("expr", ("un", "-", ("int", int(toks[i - 1][1]), loc(toks[i - 1][2])),
                                       minus), minus)
        if at("punct", "["):
            start = loc(toks[i][2])
            i += 1
            if not (at("name") or at("int")):
                return None
            kind, value, col = toks[i]
            e = ("name", value, loc(col)) if kind == "name" else ("int", int(value), loc(col))
            i += 1
            if at("punct", "+"):
                i += 1
                if not at("int"):
                    return None
                e = ("bin", "add", e, ("int", int(toks[i][1]), loc(toks[i][2])))
                i += 1
            if not at("punct", "]"):
                return None
            i += 1
            return OperandAst("mem", e, start)
        return None

    def instruction():
        nonlocal i
        if not at("name"):
            return None
        mnemonic, col = toks[i][1], toks[i][2]
        i += 1
        ops = []
        if at("name") or at("int") or at("punct", "-") or at("punct", "["):
            while True:
                o = operand()
                if o is None:
                    return None
                ops.append(o)
                if not at("punct", ","):
                    break
                i += 1
        return Instr(mnemonic, ops, loc(col))

    item = None
    if at("punct", "{"):
        start = loc(toks[i][2])
        i += 1
        instrs = []
        while True:
            ins = instruction()
            if ins is None:
                return None
            instrs.append(ins)
            if at("punct", ";"):
                i += 1
                continue
            break
        if not at("punct", "}"):
            return None
        i += 1
        item = Bundle(instrs, start)
    elif i < len(toks):
        item = instruction()
        if item is None:
            return None
    if i != len(toks) or (item is None and not labels):
        return None
    return Statement(labels, item, Loc(file, line, 1, via), chunk.source_lines)


def parse_chunk(chunk: Chunk) -> Statement | Diagnostic:
    """Parse one logical statement; a syntax error comes back as a located Diagnostic, and so
    does a statement longer than limits.MAX_STATEMENT_CHARS or an expression deeper than
    limits.MAX_EXPRESSION_DEPTH (the tree is walked recursively afterwards)."""
    from netsushisen.isa.limits import MAX_EXPRESSION_DEPTH, MAX_STATEMENT_CHARS

    if len(chunk.text) > MAX_STATEMENT_CHARS:
        return Diagnostic(f"statement of {len(chunk.text):,} characters, more than "
                          f"{MAX_STATEMENT_CHARS:,} (limits.MAX_STATEMENT_CHARS)", chunk.file, chunk.line, 1)
    simple = _simple_statement(chunk)
    if simple is not None:
        return simple
    try:
        tree = _parse_text(chunk.text)
    except UnexpectedInput as err:
        line = chunk.line + (getattr(err, "line", 1) or 1) - 1
        col = getattr(err, "column", 1) or 1
        if isinstance(err, UnexpectedCharacters):
            ch = chunk.text.split("\n")[err.line - 1][err.column - 1:err.column]
            msg = f"syntax error: unexpected character {ch!r}"
        elif isinstance(err, UnexpectedEOF):
            msg = "syntax error: the statement ends too early"
            line = chunk.line + len(chunk.source_lines) - 1
            col = len(chunk.source_line(line).rstrip()) + 1
        elif isinstance(err, UnexpectedToken):
            tok = err.token
            if tok.type == "$END":
                msg = "syntax error: the statement ends too early"
                line = chunk.line + len(chunk.source_lines) - 1
                col = len(chunk.source_line(line).rstrip()) + 1
            else:
                shown = "end of line" if tok.type == "_NL" else repr(str(tok))
                msg = f"syntax error: unexpected {shown}"
            expected = _describe_expected(err.expected)
            if expected:
                msg += f" (expected {expected})"
        else:  # pragma: no cover - Lark's other UnexpectedInput kinds
            msg = f"syntax error: {err}"
        return Diagnostic(msg, chunk.file, line, col, chunk.source_line(line))
    if _depth(tree, MAX_EXPRESSION_DEPTH) > MAX_EXPRESSION_DEPTH:
        return Diagnostic(f"expression nested deeper than {MAX_EXPRESSION_DEPTH} levels "
                          "(limits.MAX_EXPRESSION_DEPTH: operators and parentheses)",
                          chunk.file, chunk.line, 1)
    labels, item = _ToAst(chunk).transform(tree)
    return Statement(labels, item, Loc(chunk.file, chunk.line, 1, chunk.via), chunk.source_lines)
