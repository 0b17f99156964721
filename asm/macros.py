"""`.macro`/`.endm` and `.rept`/`.endr`: text-level expansion of the source, GNU as style.

A kernel writer repeats blocks that differ only in a register, a load mnemonic or a label
suffix (IC's resident and global twin of each shape test, OS's 13-word queue copy). A macro
writes such a block once:

    .macro LOAD3 op, base, dst          # parameters: names, `name=default` for optional ones
        { \\op \\dst\\()x, [\\base] }         # \\param is replaced by the argument's text,
        { \\op \\dst\\()y, [\\base + 1] }     # \\() joins it to what follows, \\@ counts expansions
    .endm
    LOAD3 ldg, shp, c_                  # arguments: comma separated, `name=value` by keyword

    .rept 4                             # the body, 4 times over; \\+ is the
        { st r1, [r2 + \\+] }               #   iterations done so far (0, 1, 2, 3)
    .endr

Expansion works on the logical statements `parser.split_statements` cut, before they are parsed:
a body is kept as statements and every expanded statement keeps the file and line it was written
at, plus an `Expansion` naming the invocation (or `.rept`), so an error inside a body is reported
at the body's line AND at the invocation, and the listing shows which expansion a bundle came
from. Conditionals (`.if`) inside a body are evaluated at each expansion, like GNU as. The
assembler (asm/assembler.py) drives this module: `MacroExpansion`, a part of its `Assembler`,
finds the blocks, binds the arguments and assembles the expanded statements as if they were
written out; the functions before it are pure text work.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, replace
from pathlib import Path

from netsushisen.asm.parser import Chunk, Expansion, Loc, parse_chunk, parse_macro_header
from netsushisen.isa.errors import Diagnostic, NetsushisenError
from netsushisen.isa.opcodes import OPCODES
from netsushisen.isa.limits import MAX_EXPANDED_CHARS, MAX_EXPANDED_LINES, MAX_STATEMENT_CHARS

MAX_EXPANSION_DEPTH = 64
"""Macro invocations and `.rept`s nested deeper than this are an error (a macro that invokes
itself without end)."""

MAX_REPT = 1 << 16
"""The largest `.rept` count: more bundles than any processor's program memory holds."""

_LABELS = r"((?:[A-Za-z_]\w*\s*:\s*)*)"
BLOCK_RE = re.compile(_LABELS + r"\.(macro|endm|rept|endr)\b(.*)$", re.S)
INVOKE_RE = re.compile(_LABELS + r"([A-Za-z_]\w*)(?=\s|$)(.*)$", re.S)
LABEL_RE = re.compile(r"([A-Za-z_]\w*)\s*:")
_SUBST_RE = re.compile(r"\\(\(\)|@|[A-Za-z_]\w*)")


class MacroError(Exception):
    """A malformed macro header, call or body line: the message and its column (1-based)."""

    def __init__(self, message: str, col: int = 1, line: int | None = None):
        super().__init__(message)
        self.message, self.col, self.line = message, col, line


@dataclass
class Macro:
    name: str
    params: list[str]
    defaults: dict[str, str]
    body: list[Chunk]
    loc: Loc  # the `.macro` line
    order: int  # when it was defined (a use before it is an error)
    size: int = 0  # statements one invocation produces, the macros it invokes included


@dataclass
class Block:
    """A `.macro`/`.endm`/`.rept`/`.endr` line: the labels before it, which, and the rest."""

    labels: list[tuple[str, int]]  # name, column
    kind: str
    rest: str
    rest_col: int  # column of `rest` in the line


def _labels(text: str, upto: int) -> list[tuple[str, int]]:
    return [(m.group(1), m.start(1) + 1) for m in LABEL_RE.finditer(text[:upto])]


def block_directive(chunk: Chunk) -> Block | None:
    """The block directive a statement is, if it is one."""
    stripped = chunk.text.lstrip()
    m = BLOCK_RE.match(stripped)
    if not m:
        return None
    lead = len(chunk.text) - len(stripped)
    return Block([(n, c + lead) for n, c in _labels(stripped, m.end(1))], m.group(2),
                 m.group(3), m.start(3) + lead + 1)


def find_end(chunks: list[Chunk], start: int, kind: str) -> int | None:
    """Index of the `.endm` (kind "macro") or `.endr` ("rept") closing a block whose body starts
    at `start`, counting nested blocks of the same kind; None if the file ends first."""
    closer = {"macro": "endm", "rept": "endr"}[kind]
    depth = 0
    for i in range(start, len(chunks)):
        b = block_directive(chunks[i])
        if b is None:
            continue
        if b.kind == kind:
            depth += 1
        elif b.kind == closer:
            if depth == 0:
                return i
            depth -= 1
    return None


def parse_header(rest: str, col: int) -> tuple[str, list[str], dict[str, str]]:
    """`NAME [param[=default] [, param...]]` of a `.macro` line (grammar.lark's `macro_header`;
    parameters may also be separated by spaces, as GNU as allows). `col`: where `rest` starts."""
    if not rest.strip():
        raise MacroError(".macro needs a name: .macro NAME [param[=default], ...]", col)
    parsed = parse_macro_header(rest)
    if isinstance(parsed[1], int):
        raise MacroError(f"bad .macro line: {parsed[0]} (write .macro NAME [param[=default], "
                         "...])", col + parsed[1] - 1)
    name, items = parsed
    params: list[str] = []
    defaults: dict[str, str] = {}
    for pname, default, pcol in items:
        if pname in params:
            raise MacroError(f"macro '{name}' names parameter '{pname}' twice", col + pcol - 1)
        params.append(pname)
        if default is not None:
            defaults[pname] = default
    return name, params, defaults


def split_args(text: str) -> list[str]:
    """Top-level comma-separated pieces of `text` (commas inside [], (), {} or strings do not
    split: a whole bundle can be one argument); an empty text is no argument."""
    if not text.strip():
        return []
    out, depth, cur, in_string, i = [], 0, [], False, 0
    while i < len(text):
        c = text[i]
        if in_string:
            if c == "\\" and i + 1 < len(text):
                cur.append(c)
                i += 1
                c = text[i]
            elif c == '"':
                in_string = False
        elif c == '"':
            in_string = True
        elif c in "([{":
            depth += 1
        elif c in ")]}":
            depth -= 1
        elif c == "," and depth == 0:
            out.append("".join(cur))
            cur = []
            i += 1
            continue
        cur.append(c)
        i += 1
    out.append("".join(cur))
    return out


def bind(macro: Macro, args_text: str, col: int) -> dict[str, str]:
    """The parameters' values for one invocation: positional arguments, then `name=value` ones,
    then defaults; a missing argument without a default or one too many is an error."""
    values: dict[str, str] = {}
    positional = True
    want = ", ".join(p + (f"={macro.defaults[p]}" if p in macro.defaults else "")
                     for p in macro.params) or "no arguments"
    for k, raw in enumerate(split_args(args_text)):
        arg = raw.strip()
        m = re.match(r"([A-Za-z_]\w*)\s*=(?!=)(.*)$", arg, re.S)
        if m and m.group(1) in macro.params:
            positional = False
            if m.group(1) in values:
                raise MacroError(f"macro '{macro.name}': argument '{m.group(1)}' given twice", col)
            values[m.group(1)] = m.group(2).strip()
            continue
        if not positional:
            raise MacroError(f"macro '{macro.name}': a positional argument after a keyword one",
                             col)
        if k >= len(macro.params):
            raise MacroError(f"macro '{macro.name}' takes {len(macro.params)} argument"
                             f"{'s' if len(macro.params) != 1 else ''} ({want}), got "
                             f"{len(split_args(args_text))}", col)
        if arg:
            values[macro.params[k]] = arg
    missing = [p for p in macro.params if p not in values and p not in macro.defaults]
    if missing:
        raise MacroError(f"macro '{macro.name}' needs argument{'s' if len(missing) > 1 else ''} "
                         f"{', '.join(repr(p) for p in missing)} ({want})", col)
    return {p: values.get(p, macro.defaults.get(p, "")) for p in macro.params}


def substitute(chunk: Chunk, macro: Macro, values: dict[str, str], counter: int,
               via: Expansion) -> Chunk:
    """One body statement with `\\param`, `\\()` and `\\@` replaced; an unknown `\\name` in the
    code (not in a comment) is a MacroError at its line and column."""
    for n, line in enumerate(chunk.text.split("\n")):
        for m in _SUBST_RE.finditer(line):
            key = m.group(1)
            if key not in ("()", "@") and key not in values:
                have = ", ".join(macro.params) or "none"
                raise MacroError(f"'\\{key}' is not a parameter of macro '{macro.name}' "
                                 f"(its parameters: {have})", m.start() + 1, chunk.line + n)

    def sub(m: re.Match) -> str:
        key = m.group(1)
        if key == "()":
            return ""
        if key == "@":
            return str(counter)
        return values.get(key, m.group(0))

    return Chunk(_SUBST_RE.sub(sub, chunk.text), chunk.file, chunk.line,
                 [_SUBST_RE.sub(sub, s) for s in chunk.source_lines], via)


def static_size(body: list[Chunk], macros: dict[str, Macro]) -> int:
    """Statements `body` produces at least: one a line, plus each invoked macro's own size (a
    `.rept` inside counts its lines once here and charges its count when it runs); capped just
    past limits.MAX_EXPANDED_LINES."""
    size = 0
    for c in body:
        call = INVOKE_RE.match(c.text.lstrip())
        size += 1 + (macros[call.group(2)].size if call and call.group(2) in macros else 0)
        if size > MAX_EXPANDED_LINES:
            return MAX_EXPANDED_LINES + 1
    return size


def repetition(body: list[Chunk], via: Expansion) -> list[Chunk]:
    """One repetition's copy of a `.rept` body: `\\+` (the iterations done so far, from 0, as
    GNU as) replaced in the body's own lines; a nested `.rept`'s lines keep theirs."""
    out, depth = [], 0
    for chunk in body:
        b = block_directive(chunk)
        if b is not None and b.kind in ("rept", "endr"):
            depth += 1 if b.kind == "rept" else -1
        if depth == 0 and "\\+" in chunk.text:
            n = str(via.index - 1)
            chunk = replace(chunk, text=chunk.text.replace("\\+", n),
                            source_lines=[s.replace("\\+", n) for s in chunk.source_lines])
        out.append(replace(chunk, via=via))
    return out


STRAY_RE = re.compile(r"\\(\(\)|@|\+|[A-Za-z_]\w*)")


def stray_escape(text: str) -> tuple[str, int] | None:
    """A `\\name`, `\\@`, `\\()` or `\\+` left in a statement (outside strings) after expansion:
    what it is and its column, or None."""
    m = STRAY_RE.search(text)
    if m is None or text[:m.start()].count('"') % 2:
        return None
    return m.group(0), m.start() + 1


def describe(via: Expansion | None, lines: dict) -> str:
    """`file:line: invocation` for each expansion a bundle is in, outermost first, for the
    listing; "" outside any."""
    parts = []
    while via is not None:
        at = via.at
        text = (lines.get((at.file, at.line, at.via)) or "").strip()
        what = f"{text}  [{via.index} of {via.name}]" if via.kind == "rept" else text
        parts.append(f"{at.file}:{at.line}: {what}")
        via = at.via
    return " > ".join(reversed(parts))


class MacroExpansion:
    """The assembler's handling of `.macro`/`.rept` blocks and macro invocations (a mixin of
    `assembler.Assembler`: it uses its state `st`, `_statements`, `_define_label` and `_eval`)."""

    def _block(self, block, chunk: Chunk, chunks: list[Chunk], i: int, base_dir: Path,
               stack: list[str], depth: int) -> int:
        """A `.macro`, `.rept` or stray `.endm`/`.endr` line at chunks[i - 1]: define or expand
        the block; returns the index of the statement after it."""
        st = self.st

        def loc(col: int) -> Loc:
            return Loc(chunk.file, chunk.line, col, chunk.via)

        for name, col in block.labels:
            self._define_label(name, loc(col))
        at = loc(block.rest_col - len(block.kind) - 1)
        if block.kind in ("endm", "endr"):
            opener = "macro" if block.kind == "endm" else "rept"
            st.error(f".{block.kind} without a matching .{opener}", at)
            return i
        end = find_end(chunks, i, block.kind)
        closer = "endm" if block.kind == "macro" else "endr"
        if block.kind == "macro":
            try:
                name, params, defaults = parse_header(block.rest, block.rest_col)
            except MacroError as err:
                st.error(err.message, loc(err.col))
                return len(chunks) if end is None else end + 1
            if end is None:
                st.error(f"unterminated .macro '{name}': no .{closer} before the end of the "
                         "file", at)
                return len(chunks)
            from netsushisen.asm.assembler import register_index

            if name in OPCODES or register_index(name) is not None:
                st.error(f"'{name}' is {'an instruction' if name in OPCODES else 'a register'}"
                         "; a macro cannot take its name", at)
            elif name in st.macros:
                prev = st.macros[name].loc
                st.error(f"macro '{name}' is already defined (at {prev.file}:{prev.line})", at)
            else:
                body = chunks[i:end]
                st.macros[name] = Macro(name, params, defaults, body, at, st.order,
                                        static_size(body, st.macros))
            return end + 1
        if end is None:
            st.error(f"unterminated .rept: no .{closer} before the end of the file", at)
            return len(chunks)
        parsed = parse_chunk(chunk)  # `.rept N` is an ordinary directive to the grammar
        count = None
        if isinstance(parsed, Diagnostic) or len(parsed.item.args) != 1 \
                or parsed.item.args[0].kind != "expr":
            st.error(".rept takes one count: .rept N", at)
        else:
            arg = parsed.item.args[0]
            count = self._eval(arg.value, arg.loc, allow_labels=False)
            if count is not None and (not isinstance(count, int) or not 0 <= count <= MAX_REPT):
                st.error(f".rept needs a count from 0 to {MAX_REPT}, got {count!r}", arg.loc)
                count = None
        if count is not None and self._deep_enough(at, depth):
            self._charge(count * static_size(chunks[i:end], st.macros), at)
            outer = st.repeat
            st.repeat = min(outer * max(count, 1), MAX_EXPANDED_LINES + 1)
            try:
                for r in range(1, count + 1):
                    via = Expansion("rept", f"{count}", at, r)
                    self._expand(repetition(chunks[i:end], via), base_dir, stack, depth)
            finally:
                st.repeat = outer
        return end + 1

    def _charge(self, lines: int, at: Loc) -> None:
        """Count the statements an expansion will produce — times every enclosing .rept's
        count, before any is produced — against limits.MAX_EXPANDED_LINES: nested .rept
        blocks and macros that invoke macros stop at once, one line naming the limit."""
        st = self.st
        st.expanded_lines += lines * st.repeat
        if st.expanded_lines > MAX_EXPANDED_LINES:
            raise NetsushisenError(Diagnostic(
                f"macros and .rept would produce more than {MAX_EXPANDED_LINES:,} statements "
                "(limits.MAX_EXPANDED_LINES, macros and .rept together)", at.file, at.line, at.col))

    def _charge_chars(self, body: list[Chunk], at: Loc) -> None:
        st = self.st
        for c in body:
            if len(c.text) > MAX_STATEMENT_CHARS:
                raise NetsushisenError(Diagnostic(
                    f"a statement of this expansion is {len(c.text):,} characters long, more than "
                    f"{MAX_STATEMENT_CHARS:,} (limits.MAX_STATEMENT_CHARS)", at.file, at.line, at.col))
            st.expanded_chars += len(c.text)
        if st.expanded_chars > MAX_EXPANDED_CHARS:
            raise NetsushisenError(Diagnostic(
                f"macro substitution would produce more than {MAX_EXPANDED_CHARS:,} characters "
                "(limits.MAX_EXPANDED_CHARS)", at.file, at.line, at.col))

    def _deep_enough(self, at: Loc, depth: int) -> bool:
        if depth < MAX_EXPANSION_DEPTH:
            return True
        self.st.error(f"macro / .rept expansions nested deeper than {MAX_EXPANSION_DEPTH} "
                      "(does a macro invoke itself?)", at)
        return False

    def _invoke(self, chunk: Chunk, call, base_dir: Path, stack: list[str], depth: int) -> None:
        st = self.st
        lead = len(chunk.text) - len(chunk.text.lstrip())
        for name, col in [(m.group(1), m.start(1) + 1) for m in
                          re.finditer(r"([A-Za-z_]\w*)\s*:", call.group(1))]:
            self._define_label(name, Loc(chunk.file, chunk.line, col + lead, chunk.via))
        macro = st.macros[call.group(2)]
        at = Loc(chunk.file, chunk.line, call.start(2) + lead + 1, chunk.via)
        args_col = call.start(3) + lead + 1
        try:
            values = bind(macro, call.group(3), args_col + len(call.group(3)) - len(call.group(3).lstrip()))
        except MacroError as err:
            st.error(err.message, Loc(at.file, at.line, err.col, at.via))
            return
        if not self._deep_enough(at, depth):
            return
        self._charge(macro.size, at)
        counter = st.expansions  # \@: macros expanded before this one (GNU as counts from 0)
        st.expansions += 1
        via = Expansion("macro", macro.name, at)
        body = []
        for c in macro.body:
            try:
                body.append(substitute(c, macro, values, counter, via))
            except MacroError as err:
                for n, line in enumerate(c.source_lines):
                    st.lines[(c.file, c.line + n, via)] = line
                st.error(err.message, Loc(c.file, err.line or c.line, err.col, via))
        self._charge_chars(body, at)
        outer, shadowable = st.aliases, st.shadowable
        st.shadowable = frozenset(outer)
        self._expand(body, base_dir, stack, depth)
        self.local_names(outer, shadowable)

    def _expand(self, body: list[Chunk], base_dir: Path, stack: list[str], depth: int) -> None:
        for c in body:
            for n, line in enumerate(c.source_lines):
                self.st.lines[(c.file, c.line + n, c.via)] = line
        self._statements(body, base_dir, stack, depth + 1)
