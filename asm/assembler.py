"""The assembler: statements to a `Program`, with every error of a source reported at once.

Pass 1 walks the statements in order — expanding `.include`, following `.if`/`.elif`/`.else`/
`.endif`, defining `.equ` constants and `.reg` aliases, placing labels (code labels count bundles,
data labels count local words). Pass 2 resolves each operation's operands against the complete
symbol table and runs the resource checker on every bundle; then, if the source has `.sched`
regions (one operation per line in pass 1), it schedules them for `config`, moves the code labels
to where their blocks landed and resolves the operations again (asm/regions.py). Diagnostics
from both passes are reported in source order as `file:line:col: error: message` with the line
and a caret.
"""

from __future__ import annotations

import difflib
import os
import re
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path

from netsushisen.asm.aliasing import clashes, merge, operand_names, successors
from netsushisen.asm.checker import check_bundle
from netsushisen.asm.expressions import BUILTIN_CONSTANTS, ExprError, evaluate, names_in
from netsushisen.asm.macros import (INVOKE_RE, Macro, MacroExpansion, block_directive, describe,
                                    stray_escape)
from netsushisen.asm.objects import Op, Program, RegName, SourceLoc
from netsushisen.asm.pipeline import PipelineReport
from netsushisen.asm.regions import MAX_REGION_LABELS, MAX_REGION_OPS, Region, RegionAssembly, RegionLoop
from netsushisen.asm.parser import (CONDITIONAL_RE, Bundle, Chunk, Directive, Expansion, Instr,
                                    Loc, parse_chunk, split_statements)
from netsushisen.isa.errors import Diagnostic, NetsushisenError
from netsushisen.isa.config import MachineConfig
from netsushisen.isa.opcodes import OPCODES
from netsushisen.isa.processors import N_REGISTERS, PROCESSORS, REGISTER_ALIASES
from netsushisen.isa.ring import predefined_symbols
from netsushisen.isa.words import wrap32

MAX_INCLUDE_DEPTH = 32
DIRECTIVES = ("proc", "equ", "reg", "include", "if", "ifdef", "ifndef", "elif", "else", "endif",
              "text", "data", "word", "float", "space", "align", "error",
              "macro", "endm", "rept", "endr", "sched", "endsched", "pipeline", "temps", "deadout",
              "unreg", "vreg")
_REG_RE = re.compile(r"r(\d+)$")


class AssemblyError(NetsushisenError):
    """A kernel source with errors; `diagnostics` holds every one of them."""


def kernels_dir() -> Path:
    """The bundled kernels (always searched last for `.include`)."""
    return Path(str(resources.files("netsushisen.kernels")))


@dataclass
class _Symbol:
    value: int | float
    kind: str  # predefined, define, equ, text, data
    loc: Loc | None


@dataclass
class _PendingBundle:
    instrs: list[Instr]
    loc: Loc
    text: str
    order: int
    region: int = -1  # the .sched region it belongs to
    aliases: dict[str, tuple[int, Loc]] = field(default_factory=dict)
    """The `.reg` names in force at this bundle: pass 2 resolves its operands with them."""


@dataclass
class _Cond:
    active: bool  # this branch is being assembled
    taken: bool  # some branch of this .if has been taken
    parent_active: bool
    loc: Loc
    seen_else: bool = False


@dataclass
class _State:
    proc: str | None
    proc_from_caller: bool
    include_dirs: list[Path]
    symbols: dict[str, _Symbol] = field(default_factory=dict)
    aliases: dict[str, tuple[int, Loc]] = field(default_factory=dict)
    """The `.reg` names in force here (replaced, never mutated, so a bundle keeps its own)."""
    reg_scopes: list[list] = field(default_factory=list)  # [name, reg, first bundle, end|None]
    shadowable: frozenset[str] = frozenset()
    """Names from outside the macro expansion being assembled: its own `.reg` may shadow them."""
    bundles: list[_PendingBundle] = field(default_factory=list)
    data: list[tuple[str, object, Loc, int]] = field(default_factory=list)  # kind, expr|value, loc, order
    section: str = "text"
    diags: list[tuple[int, int, Diagnostic]] = field(default_factory=list)
    order: int = 0
    lines: dict[tuple[str, int, Expansion | None], str] = field(default_factory=dict)
    """(file, line, expansion) -> the source line as assembled (a body line after substitution)."""
    macros: dict[str, Macro] = field(default_factory=dict)
    expansions: int = 0  # macro invocations so far: `\@`
    expanded_lines: int = 0  # statements macros and .rept will produce (macros.charge_lines)
    expanded_chars: int = 0  # characters macro substitution produced
    repeat: int = 1  # the product of the counts of the .rept blocks being expanded
    regions: list[Region] = field(default_factory=list)
    region: Region | None = None  # the open one
    pipeline_mark: Loc | None = None  # a `.pipeline` waiting for its loop's label

    def error(self, message: str, loc: Loc | None, order: int | None = None) -> None:
        src = self.lines.get((loc.file, loc.line, loc.via)) if loc else None
        self.add((self.order if order is None else order, loc.col if loc else 0),
                 Diagnostic(message, loc.file if loc else None, loc.line if loc else None,
                            loc.col if loc else None, src), loc.via if loc else None)

    def add(self, key: tuple[int, int], diag: Diagnostic, via: Expansion | None) -> None:
        """A diagnostic, then a note for each macro / .rept expansion it lies in (innermost
        first, as GNU as and compilers print them): the line inside the body and the invocation
        are both named."""
        self.diags.append((*key, diag))
        chain = []
        while via is not None:
            chain.append(via)
            via = via.at.via
        if len(chain) > 5:  # a runaway recursion: the innermost few and the first invocation
            chain = chain[:3] + [None] + chain[-1:]
        for via in chain:
            if via is None:
                self.diags.append((*key, Diagnostic("... (more expansions)", severity="note")))
                continue
            at = via.at
            what = (f"in expansion of macro '{via.name}'" if via.kind == "macro"
                    else f"in repetition {via.index} of {via.name} (.rept)")
            self.diags.append((*key, Diagnostic(what, at.file, at.line, at.col,
                                                self.lines.get((at.file, at.line, at.via)),
                                                severity="note")))


def register_index(name: str, aliases: dict[str, tuple[int, Loc]] | None = None) -> int | None:
    """The register a name denotes (r0..r63, zero, lr, or a `.reg` alias), else None."""
    if aliases and name in aliases:
        return aliases[name][0]
    if name in REGISTER_ALIASES:
        return REGISTER_ALIASES[name]
    m = _REG_RE.match(name)
    if m and int(m.group(1)) < N_REGISTERS and (m.group(1) == "0" or not m.group(1).startswith("0")):
        return int(m.group(1))
    return None


def _operand_names(instr: Instr) -> set[str]:
    return {n for o in instr.operands for n, _ in names_in(o.expr)}


def _where(loc: Loc) -> str:
    return f"{loc.file}:{loc.line}:{loc.col}"


def _read_source(path: Path, display: str) -> str:
    from netsushisen.isa.limits import read_input

    data = read_input(path, "source file")
    bad = data.find(b"\x00")
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as err:
        bad = err.start if bad < 0 else min(bad, err.start)
        text = None
    if bad >= 0:
        line = data.count(b"\n", 0, bad) + 1
        col = bad - (data.rfind(b"\n", 0, bad) + 1) + 1
        raise AssemblyError(Diagnostic(
            f"not a text file: byte 0x{data[bad]:02x} cannot appear in assembly source",
            display, line, col))
    return text


class Assembler(MacroExpansion, RegionAssembly):
    def __init__(self, proc: str | None = None, defines: dict[str, int | float] | None = None,
                 include_dirs: list[str | Path] | None = None, config: MachineConfig | None = None,
                 schedule: bool = True):
        if proc is not None and proc not in PROCESSORS:
            raise NetsushisenError(f"unknown processor {proc!r}: choose os, ic or sc")
        self.defines = dict(defines or {})
        self.config = config or MachineConfig()
        """The machine `.sched` regions are scheduled for (latencies, memory times, penalty)."""
        self.schedule = schedule
        """False: `.sched` regions stay one operation per bundle, as written (the serial form)."""
        self.pipeline_reports: list[PipelineReport] = []
        """The software pipelining information of every `.pipeline` loop, in source order."""
        self.pinned: list[Loc] = []  # where each pinned `.vreg x = rN` was written
        self.warnings: list[Diagnostic] = []
        """Located warnings (two names of a register live at once outside a region)."""
        self.region_lines: set[tuple[str, int, str]] = set()
        """(file, line, expansion) of every operation in a `.sched` region (for the listing)."""
        self.st = _State(proc, proc is not None, [Path(d) for d in include_dirs or []])
        for name, value in predefined_symbols().items():
            self.st.symbols[name] = _Symbol(value, "predefined", None)
        for name, value in self.defines.items():
            if register_index(name) is not None:
                raise NetsushisenError(f"-D {name}: a register name cannot be a symbol")
            self.st.symbols[name] = _Symbol(value, "define", None)

    # -- entry points ------------------------------------------------------------------------

    def assemble_file(self, path: str | Path) -> Program:
        p = Path(path)
        display = os.path.normpath(str(path))
        if not p.is_file():
            raise AssemblyError(Diagnostic("no such source file", display))
        return self.assemble_text(_read_source(p, display), display, base_dir=p.parent)

    def assemble_text(self, text: str, filename: str = "<string>",
                      base_dir: Path | None = None) -> Program:
        st = self.st
        if "\x00" in text:
            raise AssemblyError(Diagnostic("not a text file: NUL byte in assembly source", filename))
        self._walk(text, filename, base_dir or Path.cwd(), [])
        if st.region is not None:
            st.error(".sched without a matching .endsched", st.region.loc)
            st.region.end = len(st.bundles)
            st.region = None
        if not st.bundles and not st.diags:
            st.error("empty program: the source holds no instructions", Loc(filename, 1, 1))
        program = self._resolve()
        if st.diags:
            st.diags.sort(key=lambda d: (d[0], d[1]))
            raise AssemblyError([d for _, _, d in st.diags])
        return program

    # -- pass 1 ------------------------------------------------------------------------------

    def _walk(self, text: str, file: str, base_dir: Path, stack: list[str]) -> None:
        st = self.st
        for n, line in enumerate(text.split("\n"), start=1):
            st.lines[(file, n, None)] = line
        chunks, split_errors = split_statements(text, file)
        for d in split_errors:
            st.order += 1
            st.diags.append((st.order, d.col or 0, d))
        self._statements(chunks, base_dir, stack, 0)

    def _statements(self, chunks: list[Chunk], base_dir: Path, stack: list[str],
                    depth: int) -> None:
        """Assemble a run of statements: a file's, or one macro / .rept expansion's (its
        conditionals must close inside it, as a file's must)."""
        st = self.st
        conds: list[_Cond] = []
        i = 0
        while i < len(chunks):
            chunk = chunks[i]
            i += 1
            st.order += 1
            active = not conds or conds[-1].active
            if not active and not CONDITIONAL_RE.match(chunk.text):
                continue  # skipped like a preprocessor: not even parsed
            if active:
                block = block_directive(chunk)
                if block is not None:
                    i = self._block(block, chunk, chunks, i, base_dir, stack, depth)
                    continue
                call = INVOKE_RE.match(chunk.text.lstrip())
                if call and call.group(2) in st.macros:
                    self._invoke(chunk, call, base_dir, stack, depth)
                    continue
                stray = stray_escape(chunk.text) if "\\" in chunk.text else None
                if stray is not None:
                    where = "a .rept body" if stray[0] == "\\+" else "a .macro body"
                    st.error(f"'{stray[0]}' means something only inside {where}",
                             Loc(chunk.file, chunk.line, stray[1], chunk.via))
                    continue
            parsed = parse_chunk(chunk)
            if isinstance(parsed, Diagnostic):
                st.add((st.order, parsed.col or 0), parsed, chunk.via)
                continue
            item = parsed.item
            if isinstance(item, Directive) and item.name in ("if", "ifdef", "ifndef", "elif", "else", "endif"):
                self._conditional(item, conds)
                continue
            if not active:
                continue
            for name, loc in parsed.labels:
                self._define_label(name, loc)
            if item is None:
                continue
            if isinstance(item, Directive):
                self._directive(item, base_dir, stack, chunk)
            else:
                instrs = item.instrs if isinstance(item, Bundle) else [item]
                if isinstance(item, Bundle) and st.region is not None:
                    st.error("a .sched region holds one operation per line, without braces "
                             "(the assembler makes the bundles)", item.loc)
                    continue
                self._add_bundle(instrs, item.loc, chunk)
        for c in conds:
            st.error(".if without a matching .endif", c.loc)

    def _conditional(self, d: Directive, conds: list[_Cond]) -> None:
        st = self.st
        parent_active = not conds or conds[-1].active
        if d.name in ("if", "ifdef", "ifndef"):
            value = False
            if parent_active:
                value = self._condition(d)
            conds.append(_Cond(parent_active and value, value, parent_active, d.loc))
            return
        if not conds:
            st.error(f".{d.name} without a matching .if", d.loc)
            return
        top = conds[-1]
        if d.name == "endif":
            conds.pop()
            return
        if top.seen_else:
            st.error(f".{d.name} after .else (opened at line {top.loc.line})", d.loc)
            return
        if d.name == "else":
            top.seen_else = True
            top.active = top.parent_active and not top.taken
            top.taken = True
            return
        value = False  # .elif
        if top.parent_active and not top.taken:
            value = self._condition(d)
        top.active = top.parent_active and not top.taken and value
        top.taken = top.taken or value

    def _condition(self, d: Directive) -> bool:
        if d.name in ("ifdef", "ifndef"):
            if len(d.args) != 1 or d.args[0].kind != "expr" or d.args[0].value[0] != "name":
                self.st.error(f".{d.name} takes one symbol name", d.loc)
                return False
            known = self._is_defined(d.args[0].value[1])
            return known if d.name == "ifdef" else not known
        if len(d.args) != 1 or d.args[0].kind != "expr":
            self.st.error(f".{d.name} takes one expression", d.loc)
            return False
        value = self._eval(d.args[0].value, d.args[0].loc, allow_labels=False)
        return bool(value) if value is not None else False

    def _is_defined(self, name: str) -> bool:
        return name in self.st.symbols or name in self.st.aliases

    def _define_label(self, name: str, loc: Loc) -> None:
        st = self.st
        if register_index(name, st.aliases) is not None:
            st.error(f"'{name}' is a register name and cannot be a label", loc)
            return
        if name in st.symbols:
            prev = st.symbols[name]
            where = f" (first defined at {prev.loc.file}:{prev.loc.line})" if prev.loc else ""
            st.error(f"duplicate label '{name}'{where}", loc)
            return
        addr = len(st.bundles) if st.section == "text" else len(st.data)
        st.symbols[name] = _Symbol(addr, st.section, loc)
        if st.region is not None and st.section == "text":
            st.region.starts.add(addr - st.region.first)
            if len(st.region.starts) > MAX_REGION_LABELS:
                raise AssemblyError(Diagnostic(
                    f"the .sched region opened at line {st.region.loc.line} passes "
                    f"{MAX_REGION_LABELS:,} labels (asm.regions.MAX_REGION_LABELS): split it",
                    loc.file, loc.line, loc.col))
            if st.pipeline_mark is not None:
                st.region.loops.append(RegionLoop(addr - st.region.first, name,
                                                  f"{loc.file}:{loc.line}"))
                st.pipeline_mark = None

    def _add_bundle(self, instrs: list[Instr], loc: Loc, chunk: Chunk) -> None:
        st = self.st
        if st.section != "text":
            st.error("instructions belong in .text; this follows a .data directive", loc)
            return
        if st.proc is None:
            st.error("which processor? give --proc os|ic|sc or write `.proc os|ic|sc` "
                     "before the first instruction", loc)
            st.proc = "?"
        if st.pipeline_mark is not None:
            st.error(".pipeline must be followed by the loop's label", st.pipeline_mark)
            st.pipeline_mark = None
        if st.region is not None and len(st.bundles) - st.region.first >= MAX_REGION_OPS:
            raise AssemblyError(Diagnostic(
                f"the .sched region opened at line {st.region.loc.line} passes "
                f"{MAX_REGION_OPS:,} operations (asm.regions.MAX_REGION_OPS): split it or "
                "close it with .endsched sooner", loc.file, loc.line, loc.col))
        st.bundles.append(_PendingBundle(instrs, loc, chunk.source_lines[0].strip(), st.order,
                                         len(st.regions) - 1 if st.region is not None else -1,
                                         st.aliases))

    def _directive(self, d: Directive, base_dir: Path, stack: list[str], chunk: Chunk) -> None:
        st = self.st
        name, args = d.name, d.args
        if name not in DIRECTIVES:
            close = difflib.get_close_matches(name, DIRECTIVES, n=1)
            hint = f" (did you mean .{close[0]}?)" if close else ""
            st.error(f"unknown directive .{name}{hint}", d.loc)
            return
        if name == "proc":
            if len(args) != 1 or args[0].kind != "expr" or args[0].value[0] != "name" \
                    or args[0].value[1] not in PROCESSORS:
                st.error(".proc takes one of os, ic, sc", d.loc)
                return
            want = args[0].value[1]
            if st.proc not in (None, want) and st.proc != "?":
                why = "--proc says" if st.proc_from_caller else "an earlier .proc says"
                st.error(f".proc {want} contradicts {why} {st.proc}", d.loc)
                return
            if st.bundles and st.proc is None:
                st.error(".proc must come before the first instruction", d.loc)
            st.proc = want
        elif name == "equ":
            pair = self._name_value(d, "equ")
            if pair:
                sym, expr, loc = pair
                if register_index(sym, st.aliases) is not None:
                    st.error(f"'{sym}' is a register name and cannot be a constant", loc)
                elif sym in st.symbols and st.symbols[sym].kind != "define":
                    prev = st.symbols[sym]
                    where = f" (first defined at {prev.loc.file}:{prev.loc.line})" if prev.loc else " (a predefined symbol)"
                    st.error(f"'{sym}' is already defined{where}", loc)
                else:
                    value = self._eval(expr, d.loc, allow_labels=False)
                    if value is not None and st.symbols.get(sym, _Symbol(0, "", None)).kind != "define":
                        st.symbols[sym] = _Symbol(value, "equ", loc)
        elif name == "reg":
            pair = self._name_value(d, "reg")
            if pair:
                alias, expr, loc = pair
                reg = register_index(expr[1], st.aliases) if expr[0] == "name" else None
                if reg is None:
                    st.error(".reg needs a register on the right (r0..r63, zero, lr or an alias)", d.loc)
                elif register_index(alias) is not None:
                    st.error(f"'{alias}' is already a register name", loc)
                elif alias in st.symbols:
                    st.error(f"'{alias}' is already a symbol", loc)
                elif alias in st.aliases and alias not in st.shadowable:
                    st.error(f"'{alias}' is already a .reg name in this scope (r{st.aliases[alias][0]}, "
                             f"bound at {_where(st.aliases[alias][1])}); write .unreg {alias} "
                             f"first to end it", loc)
                else:
                    self._bind(alias, reg, loc)
        elif name == "unreg":
            if not args:
                st.error(".unreg takes the .reg names to end: .unreg NAME[, NAME ...]", d.loc)
            for a in args:
                alias = a.value[1] if a.kind == "expr" and a.value[0] == "name" else None
                if alias is None or alias not in st.aliases:
                    st.error(f".unreg takes a .reg name in force here, got "
                             f"'{alias or 'an expression'}'", a.loc)
                    continue
                self._unbind(alias)
        elif name == "include":
            if len(args) != 1 or args[0].kind != "string":
                st.error('.include takes one quoted file name: .include "file.inc"', d.loc)
                return
            self._include(args[0].value, args[0].loc, base_dir, stack)
        elif name in ("text", "data"):
            if args:
                st.error(f".{name} takes no arguments", d.loc)
            st.section = name
        elif name in ("word", "float"):
            if st.section != "data":
                st.error(f".{name} belongs in .data (write .data first)", d.loc)
                return
            if not args:
                st.error(f".{name} needs at least one value", d.loc)
            for a in args:
                if a.kind != "expr":
                    st.error(f".{name} takes expressions", a.loc)
                    continue
                st.data.append(("i" if name == "word" else "f", a.value, a.loc, st.order))
        elif name in ("space", "align"):
            if st.section != "data":
                st.error(f".{name} belongs in .data (write .data first)", d.loc)
                return
            if len(args) != 1 or args[0].kind != "expr":
                st.error(f".{name} takes one number", d.loc)
                return
            n = self._eval(args[0].value, args[0].loc, allow_labels=False)
            if n is None:
                return
            if not isinstance(n, int) or n < (0 if name == "space" else 1) or n > 1 << 20:
                st.error(f".{name} needs a whole number in range, got {n!r}", args[0].loc)
                return
            count = n if name == "space" else (-len(st.data)) % n
            st.data.extend(("i", ("int", 0), d.loc, st.order) for _ in range(count))
        elif name == "error":
            msg = args[0].value if args and args[0].kind == "string" else "error directive"
            st.error(msg, d.loc)
        else:
            self._sched_directive(d)

    def _bind(self, alias: str, reg: int, loc: Loc) -> None:
        """`alias` means `reg` from the next bundle on (the previous scope of the name, if
        any, ends here)."""
        st = self.st
        st.aliases = {**st.aliases, alias: (reg, loc)}
        st.shadowable = st.shadowable - {alias}
        self._end_scope(alias)
        st.reg_scopes.append([alias, reg, len(st.bundles), None])

    def _unbind(self, alias: str) -> None:
        st = self.st
        st.aliases = {k: v for k, v in st.aliases.items() if k != alias}
        self._end_scope(alias)

    def _end_scope(self, alias: str) -> None:
        for scope in self.st.reg_scopes:
            if scope[0] == alias and scope[3] is None:
                scope[3] = len(self.st.bundles)

    def local_names(self, outer: dict[str, tuple[int, Loc]], shadowable: frozenset[str]) -> None:
        """End the `.reg` names a macro expansion declared (they vanish at `.endm`) and give
        the names it shadowed their registers back (a macro is a scope of its own)."""
        st = self.st
        for alias, binding in list(st.aliases.items()):
            if outer.get(alias) != binding:
                self._unbind(alias)
        for alias, (reg, loc) in outer.items():
            if st.aliases.get(alias) != (reg, loc):
                self._bind(alias, reg, loc)
        st.shadowable = shadowable

    def _name_value(self, d: Directive, what: str):
        args = d.args
        if len(args) == 1 and args[0].kind == "assign":
            sym, expr = args[0].value
            return sym, expr, args[0].loc
        if len(args) == 2 and args[0].kind == "expr" and args[0].value[0] == "name" \
                and args[1].kind == "expr":
            return args[0].value[1], args[1].value, args[0].loc
        self.st.error(f".{what} takes NAME, value (or NAME = value)", d.loc)
        return None

    def _include(self, name: str, loc: Loc, base_dir: Path, stack: list[str]) -> None:
        st = self.st
        candidates = [base_dir] + st.include_dirs + [kernels_dir()]
        for d in candidates:
            p = d / name
            if p.is_file():
                break
        else:
            searched = ", ".join(os.path.normpath(str(d)) for d in candidates)
            st.error(f"cannot find include file '{name}' (searched: {searched})", loc)
            return
        key = str(p.resolve())
        if key in stack:
            st.error(f"include loop: '{name}' includes itself", loc)
            return
        if len(stack) >= MAX_INCLUDE_DEPTH:
            st.error(f"includes nested deeper than {MAX_INCLUDE_DEPTH}", loc)
            return
        display = os.path.normpath(str(p))
        try:
            text = _read_source(p, display)
        except AssemblyError as err:
            for d in err.diagnostics:
                st.diags.append((st.order, 0, d))
            return
        self._walk(text, display, p.parent, stack + [key])

    # -- expressions ---------------------------------------------------------------------------

    def _lookup(self, allow_labels: bool):
        st = self.st

        def lookup(name: str, loc: Loc):
            if register_index(name, st.aliases) is not None:
                raise ExprError(f"'{name}' is a register; a value is expected here", loc)
            sym = st.symbols.get(name)
            if sym is None:
                if name in BUILTIN_CONSTANTS:
                    return BUILTIN_CONSTANTS[name]
                known = [n for n in st.symbols] + list(BUILTIN_CONSTANTS)
                close = difflib.get_close_matches(name, known, n=1)
                hint = f" (did you mean '{close[0]}'?)" if close else ""
                if not close and name.isupper():  # a kernel's build symbol, as HAS_POLYGONS
                    hint = (f" (a build symbol: define it with -D {name}=VALUE; the bundled "
                            "kernels take a scene's with `asm --scene SCENE`, or include the "
                            "defines.inc `kernels export` writes)")
                raise ExprError(f"undefined symbol '{name}'{hint}", loc)
            if sym.kind in ("text", "data") and not allow_labels:
                raise ExprError(f"label '{name}' cannot be used here (only constants)", loc)
            return sym.value
        return lookup

    def _eval(self, expr, loc: Loc, allow_labels: bool = True, order: int | None = None):
        try:
            return evaluate(expr, self._lookup(allow_labels), self._is_defined)
        except ExprError as err:
            self.st.error(err.message, err.loc or loc, order)
            return None

    # -- pass 2 --------------------------------------------------------------------------------

    def _resolve(self) -> Program:
        st = self.st
        proc = PROCESSORS.get(st.proc or "")
        if not st.diags:
            self._allocate_regions()
            if st.diags:  # the allocation's error alone, not every operand it left unnamed
                st.diags.sort(key=lambda d: (d[0], d[1]))
                raise AssemblyError([d for _, _, d in st.diags])
        resolved = self._resolve_ops(proc, len(st.bundles))
        for pb, ops in zip(st.bundles, resolved):
            if proc is not None and pb.region < 0 and len(ops) == len(pb.instrs):
                for problem in check_bundle(proc, ops):
                    st.error(problem, pb.loc, pb.order)
        if not st.diags:
            self._check_aliasing(resolved)
        sources = [self._op_sources(pb) for pb in st.bundles]
        smap = [SourceLoc(pb.loc.file, pb.loc.line, pb.text, describe(pb.loc.via, st.lines))
                for pb in st.bundles]
        moved = None  # serial bundle index -> its address after scheduling
        if self.schedule and any(r.end > r.first for r in st.regions) and proc is not None \
                and not st.diags:
            bundles, op_sources, smap, moved = self._schedule(proc, resolved, sources, smap)
        else:
            bundles = [tuple(ops) for ops in resolved]
            op_sources = [tuple(s) for s in sources]
        data: list[tuple[str, int | float]] = []
        for kind, expr, loc, order in st.data:
            v = self._eval(expr, loc, allow_labels=True, order=order)
            if v is None:
                data.append((kind, 0))
            elif kind == "i":
                if isinstance(v, float):
                    st.error(f".word takes integers, got {v!r} (use .float)", loc, order)
                    v = 0
                elif not -(1 << 31) <= v < 1 << 32:
                    st.error(f".word value {v} does not fit in 32 bits", loc, order)
                data.append(("i", wrap32(v)))
            else:
                data.append(("f", float(v)))
        labels = {n: (s.kind, int(s.value)) for n, s in st.symbols.items() if s.kind in ("text", "data")}
        program = Program(st.proc if proc else "os", bundles, data, labels, smap,
                          {k: v for k, v in self.defines.items()})
        program.op_sources = [tuple(s) for s in op_sources]
        program.reg_names = self._reg_names(len(bundles), moved)
        return program

    def _reg_names(self, n: int, moved) -> list[RegName]:
        """The `.reg` scopes in bundle addresses (after scheduling, a scope edge inside a
        `.sched` region widens to the region's bundles); empty scopes left out."""
        out = []
        for name, reg, a, b in self.st.reg_scopes:
            b = len(self.st.bundles) if b is None else b
            a, b = (moved(a, False), moved(b, True)) if moved else (a, b)
            if a < min(b, n):
                out.append(RegName(name, reg, a, min(b, n)))
        return out

    def _check_aliasing(self, resolved: list[list[Op]]) -> None:
        """Two names of one register live at once (asm/aliasing.py): an error inside a `.sched`
        region, a warning on the straight lines outside them."""
        st = self.st
        accesses = []
        for pb in st.bundles:
            def register_of(name: str, aliases=pb.aliases) -> int | None:
                return register_index(name, aliases)
            accesses.append(merge([operand_names(i, register_of) for i in pb.instrs]))
        kinds = [next((op.opcode.kind for op in ops if op.opcode.is_control), "")
                 for ops in resolved]
        targets = [next((a for op in ops for o, a in zip(op.opcode.operands, op.args)
                         if o.kind == "label"), None) for ops in resolved]
        labels = {int(s.value) for s in st.symbols.values() if s.kind == "text"}
        inside = [False] * len(st.bundles)
        for r in st.regions:
            span = range(r.first, r.end)
            for k in span:
                inside[k] = True
            local = [t - r.first if t is not None and t in span else None
                     for t in targets[r.first:r.end]]
            for c in clashes(accesses[r.first:r.end], successors(kinds[r.first:r.end], local)):
                self._clash(c, r.first, "error")
        outside = [k for k in range(len(st.bundles)) if not inside[k]]
        runs: list[list[int]] = []
        for k in outside:
            if runs and runs[-1][-1] == k - 1:
                runs[-1].append(k)
            else:
                runs.append([k])
        for run in runs:
            first = run[0]
            starts = {k - first for k in run if k in labels}
            for c in clashes(accesses[first:first + len(run)],
                             successors(kinds[first:first + len(run)], [None] * len(run), starts)):
                self._clash(c, first, "warning")

    def _clash(self, c, first: int, severity: str) -> None:
        st = self.st
        pb, reader = st.bundles[first + c.at], st.bundles[first + c.read]
        loc = next((i.loc for i in pb.instrs if c.writer in _operand_names(i)), pb.loc)
        rloc = next((i.loc for i in reader.instrs if c.live in _operand_names(i)), reader.loc)
        message = (f"'{c.writer}' is written while '{c.live}' (also r{c.reg}) is live: "
                   f"'{c.live}' is read at {_where(rloc)}")
        src = st.lines.get((loc.file, loc.line, loc.via))
        diag = Diagnostic(message, loc.file, loc.line, loc.col, src, severity=severity)
        if severity == "error":
            st.add((pb.order, loc.col), diag, loc.via)
        else:
            self.warnings.append(diag)

    def _resolve_ops(self, proc, n_bundles: int) -> list[list[Op]]:
        out = []
        final_aliases = self.st.aliases
        for pb in self.st.bundles:
            self.st.aliases = pb.aliases  # a name means the register of its latest .reg here
            ops = []
            for instr in pb.instrs:
                op = self._resolve_op(instr, proc, n_bundles, pb.order)
                if op is not None:
                    ops.append(op)
            out.append(ops)
        self.st.aliases = final_aliases
        return out

    def _op_sources(self, pb: _PendingBundle) -> list[SourceLoc]:
        """One location per operation: its own line (a bundle may span lines)."""
        st = self.st
        out = []
        for instr in pb.instrs:
            loc = instr.loc
            text = (st.lines.get((loc.file, loc.line, loc.via)) or pb.text).strip()
            out.append(SourceLoc(loc.file, loc.line, text, describe(loc.via, st.lines)))
        return out

    def _resolve_op(self, instr: Instr, proc, n_bundles: int, order: int) -> Op | None:
        st = self.st
        opcode = OPCODES.get(instr.mnemonic)
        if opcode is None:
            macro = st.macros.get(instr.mnemonic)
            if macro is not None:  # defined further down: GNU as wants it defined first too
                st.error(f"macro '{macro.name}' is used before its definition (at "
                         f"{macro.loc.file}:{macro.loc.line})", instr.loc, order)
                return None
            close = difflib.get_close_matches(instr.mnemonic, list(OPCODES) + list(st.macros), n=1)
            hint = ""
            if close:
                hint = f" (did you mean {'macro ' if close[0] in st.macros else ''}'{close[0]}'?)"
            what = "mnemonic or macro" if st.macros else "mnemonic"
            st.error(f"unknown {what} '{instr.mnemonic}'{hint}", instr.loc, order)
            return None
        if proc is not None and proc.name not in opcode.procs:
            have = ", ".join(sorted(p.upper() for p in opcode.procs))
            st.error(f"'{instr.mnemonic}' is not available on {proc.name.upper()} (only {have})",
                     instr.loc, order)
            return None
        want = len(opcode.operands)
        if len(instr.operands) != want:
            st.error(f"'{instr.mnemonic}' takes {want} operand{'s' if want != 1 else ''} "
                     f"({opcode.syntax}), got {len(instr.operands)}", instr.loc, order)
            return None
        args = []
        ok = True
        for i, (spec, operand) in enumerate(zip(opcode.operands, instr.operands), start=1):
            value = self._operand(instr, i, spec, operand, proc, n_bundles, order)
            if value is None:
                ok = False
            args.append(value)
        return Op(instr.mnemonic, tuple(args)) if ok else None

    def _operand(self, instr: Instr, i: int, spec, operand, proc, n_bundles: int, order: int):
        st = self.st
        where = f"operand {i} of '{instr.mnemonic}'"

        def fail(msg: str, loc: Loc | None = None):
            st.error(f"{where}: {msg}", loc or operand.loc, order)
            return None

        expr = operand.expr
        if spec.kind in ("rd", "rs"):
            if operand.kind != "expr" or expr[0] != "name" or register_index(expr[1], st.aliases) is None:
                return fail("expected a register (r0..r63, zero, lr or a .reg alias)")
            return register_index(expr[1], st.aliases)
        if spec.kind == "mem":
            if operand.kind != "mem":
                return fail("expected a memory operand [reg + offset]")
            return self._memref(expr, operand.loc, fail, order)
        if operand.kind == "mem":
            return fail("a memory operand [...] is not allowed here")
        if spec.kind == "port":
            if proc is None:
                return None  # the missing processor is already reported
            ports = proc.send_ports if OPCODES[instr.mnemonic].sends_to_port else proc.recv_ports
            if expr[0] != "name" or expr[1] not in ports:
                return fail(f"expected a FIFO port of {proc.name.upper()}: {', '.join(ports)}")
            return expr[1]
        value = self._eval(expr, operand.loc, allow_labels=True, order=order)
        if value is None:
            return None
        if spec.kind == "fimm":
            return float(value)
        if isinstance(value, float):
            return fail(f"expected an integer, got {value!r}")
        if spec.kind == "label":
            if expr[0] == "name" and st.symbols.get(expr[1]) and st.symbols[expr[1]].kind == "data":
                return fail(f"'{expr[1]}' is a data label, not a code label")
            if not 0 <= value < n_bundles:
                return fail(f"branch target {value} is outside the program (0..{n_bundles - 1})")
            return value
        if not -(1 << 31) <= value < 1 << 32:
            return fail(f"immediate {value} does not fit in 32 bits")
        return wrap32(value)

    def _memref(self, expr, loc: Loc, fail, order: int):
        st = self.st
        regs = [(n, l) for n, l in names_in(expr) if register_index(n, st.aliases) is not None]
        if len(regs) > 1:
            return fail("a memory operand has one base register")
        if not regs:
            offset = self._eval(expr, loc, order=order)
            base = 0
        else:
            reg_name = regs[0][0]
            base = register_index(reg_name, st.aliases)
            if expr[0] == "name":
                offset = 0
            elif expr[0] == "bin" and expr[1] == "add" and expr[2][0] == "name" and expr[2][1] == reg_name:
                offset = self._eval(expr[3], loc, order=order)
            elif expr[0] == "bin" and expr[1] == "add" and expr[3][0] == "name" and expr[3][1] == reg_name:
                offset = self._eval(expr[2], loc, order=order)
            elif expr[0] == "bin" and expr[1] == "sub" and expr[2][0] == "name" and expr[2][1] == reg_name:
                offset = self._eval(expr[3], loc, order=order)
                offset = -offset if offset is not None else None
            else:
                return fail("write a memory operand as [reg], [reg + offset], [reg - offset] or [offset]")
        if offset is None:
            return None
        if isinstance(offset, float):
            return fail(f"a memory offset must be an integer, got {offset!r}")
        if not -(1 << 31) <= offset < 1 << 31:
            return fail(f"memory offset {offset} does not fit in 32 bits")
        return (base, offset)


def assemble_file(path: str | Path, proc: str | None = None,
                  defines: dict[str, int | float] | None = None,
                  include_dirs: list[str | Path] | None = None,
                  config: MachineConfig | None = None, schedule: bool = True) -> Program:
    """Assemble a source file (`.sched` regions scheduled for `config`, else the default
    machine; without `schedule`, one operation per bundle as written); raises AssemblyError
    listing every error."""
    return Assembler(proc, defines, include_dirs, config, schedule).assemble_file(path)


def assemble_text(text: str, proc: str | None = None, filename: str = "<string>",
                  defines: dict[str, int | float] | None = None,
                  include_dirs: list[str | Path] | None = None,
                  config: MachineConfig | None = None) -> Program:
    """Assemble source text (tests, generated kernels); raises AssemblyError."""
    return Assembler(proc, defines, include_dirs, config).assemble_text(text, filename)


def read_constants(path: str | Path, defines: dict[str, int | float] | None = None) -> dict[str, int | float]:
    """The `.equ` constants an include file defines (so Python code shares a kernel include's
    numbers instead of typing them again); raises AssemblyError on a bad file."""
    asm = Assembler(None, defines)
    p = Path(path)
    display = os.path.normpath(str(path))
    if not p.is_file():
        raise AssemblyError(Diagnostic("no such include file", display))
    asm._walk(_read_source(p, display), display, p.parent, [])
    if asm.st.diags:
        asm.st.diags.sort(key=lambda d: (d[0], d[1]))
        raise AssemblyError([d for _, _, d in asm.st.diags])
    return {n: s.value for n, s in asm.st.symbols.items() if s.kind == "equ"}
