"""Expressions of the debugger: the assembler's expression language over the machine's state.

An expression is an assembler expression (C operators and precedence, `asm/expressions.py`,
parsed by the assembler's own grammar) in which names also denote the machine's state:

    r5, zero, lr        a register of the viewed processor, as a signed 32-bit integer
    pc, cycle           the viewed processor's PC; the machine's cycle count
    loop, table         a label of the viewed program: code labels give a bundle address, data
                        labels a local word address; -D symbols and DEST_*/HDR_* constants too
    local[E]            a word of memory, E an expression: local, resident, icgm, scgm, global
                        (the viewed processor's ICGM or SCGM)
    pri, ic.pri         a `.reg` name of the program: the register it names at that
                        processor's PC (asm/regnames.py); registers show as `pri/r29`
    ic.r5, pe1.sc.local[3]   the same for another processor or PE
    f:r5, f:local[E]    the float view of a word; i: signed (default), u: unsigned, x: raw word

Float literals may carry a C suffix (`1.5f`). A reference (register, memory word, pc) is also
a place that `set` writes and `watch` watches.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field

from netsushisen.asm.expressions import ExprError, evaluate
from netsushisen.asm.parser import Chunk, Instr, parse_chunk
from netsushisen.asm.regnames import register_names
from netsushisen.isa.errors import Diagnostic
from netsushisen.isa.processors import N_REGISTERS, REGISTER_ALIASES
from netsushisen.isa.ring import predefined_symbols
from netsushisen.isa.words import wrap32

REGIONS = ("local", "resident", "icgm", "scgm", "global")
VIEWS = ("f", "i", "u", "x")

_REF = re.compile(r"(?:(?P<view>[fiux]):)?(?:pe(?P<pe>\d+)\.)?(?:(?P<proc>os|ic|sc)\.)?"
                  r"(?:(?P<region>local|resident|icgm|scgm|global)\s*\[|"
                  r"(?P<reg>r\d+|zero|lr|pc)\b)")
_FLOAT_SUFFIX = re.compile(r"(?<![\w.])((?:\d+\.\d*|\.\d+)(?:[eE][+-]?\d+)?|\d+[eE][+-]?\d+)[fF]\b")
_QUALIFIER = re.compile(r"^\s*(?:pe(?P<pe>\d+)\.)?(?:(?P<proc>os|ic|sc)\.)?(?P<rest>.*)$", re.S)


_NAME = re.compile(r"(?<![\w.:])(?P<q>(?:[fiux]:)?(?:pe(?P<pe>\d+)\.)?(?:(?P<proc>os|ic|sc)\.)?)"
                   r"(?P<name>[A-Za-z_]\w*)\b")
_RESERVED = {"zero", "lr", "pc", "cycle", "inf", "nan", *REGIONS, "os", "ic", "sc"}


def reg_label(core, reg: int) -> str:
    """A register as the screen shows it: `pri/r29` where the program names it at the
    processor's PC, else `r29` (`r0`, `lr`)."""
    prog = core.program
    if prog is not None and prog.reg_names and prog.bundles:
        return register_names(prog).label(reg, min(core.pc, len(prog.bundles) - 1))
    return {0: "r0", 63: "lr"}.get(reg, f"r{reg}")


_FILE_LINE = re.compile(r"^(?P<file>[^\s:()\[\]]+):(?P<line>\d+)$")


def bundle_lines(program, addr: int) -> list[tuple[str, int]]:
    """The source lines (file, line) of bundle `addr`, in the order its operations name them:
    one for a bundle written out, several for a bundle a `.sched` region scheduled from
    operations of several lines (`Program.op_sources`)."""
    ops = program.op_sources[addr] if addr < len(program.op_sources) else ()
    if ops:
        return list(dict.fromkeys((s.file, s.line) for s in ops))
    smap = program.source_map
    return [(smap[addr].file, smap[addr].line)] if addr < len(smap) else []


def same_file(path: str, asked: str) -> bool:
    """Whether `asked` names the source file `path` (as given, or by its trailing parts)."""
    path, asked = path.replace("\\", "/"), asked.replace("\\", "/")
    return path == asked or path.endswith("/" + asked.lstrip("./")) or \
        asked.endswith("/" + path.lstrip("./")) or path.lstrip("./") == asked.lstrip("./")


class DebugError(Exception):
    """A bad command, expression or location: one line, and the prompt comes back."""


@dataclass(frozen=True)
class Place:
    """Something with a value: a register, a memory word or a PC, of one processor."""

    kind: str  # "reg", "mem", "pc"
    pe: int
    stage: str
    index: int = 0  # register number or word address
    region: str = ""  # mem: local, resident, icgm, scgm
    view: str = ""  # "", f, i, u, x
    label: str = field(default="", compare=False)  # a register's `pri/r29`

    def name(self, qualify: bool = False) -> str:
        q = f"pe{self.pe}.{self.stage}." if qualify else ""
        if self.kind == "reg":
            base = self.label or {0: "r0", 63: "lr"}.get(self.index, f"r{self.index}")
            text = q + base
        elif self.kind == "pc":
            text = q + "pc"
        elif self.region in ("icgm", "scgm"):
            text = f"{self.region}[{self.index}]"
        else:
            text = f"{q}{self.region}[{self.index}]"
        return f"{self.view}:{text}" if self.view else text

    def with_view(self, view: str) -> "Place":
        return Place(self.kind, self.pe, self.stage, self.index, self.region, view, self.label)


class Context:
    """Evaluates expressions and reads/writes places, relative to one viewed processor."""

    def __init__(self, machine, pe: int, stage: str):
        self.machine = machine
        if not 0 <= pe < len(machine.pes):
            raise DebugError(f"no PE {pe} (the machine has {len(machine.pes)})")
        self.pe = pe
        self.stage = stage

    # -- the machine's parts ------------------------------------------------------------------

    def core(self, pe: int | None = None, stage: str | None = None):
        pe = self.pe if pe is None else pe
        if not 0 <= pe < len(self.machine.pes):
            raise DebugError(f"no PE {pe} (the machine has {len(self.machine.pes)})")
        return self.machine.pes[pe].cores[stage or self.stage]

    def program(self, stage: str | None = None):
        return self.machine.programs.get(stage or self.stage)

    def memory_array(self, place: Place):
        m = self.machine
        if place.region == "icgm":
            return m.globals["ic"].words
        if place.region == "scgm":
            return m.globals["sc"].words
        mem = m.pes[place.pe].memories[place.stage]
        if place.region == "local":
            return mem.local.words
        if mem.resident is None:
            raise DebugError(f"{place.stage.upper()} has no resident memory")
        return mem.resident.words

    # -- places -------------------------------------------------------------------------------

    def make_place(self, kind: str, pe: int | None, stage: str | None, index: int = 0,
                   region: str = "", view: str = "") -> Place:
        pe = self.pe if pe is None else pe
        stage = stage or self.stage
        if not 0 <= pe < len(self.machine.pes):
            raise DebugError(f"no PE {pe} (the machine has {len(self.machine.pes)})")
        if kind == "mem":
            if region == "global":
                if stage == "os":
                    raise DebugError("OS has no global memory (use icgm or scgm)")
                region = "icgm" if stage == "ic" else "scgm"
            if region == "resident" and stage == "os":
                raise DebugError("OS has no resident memory")
            place = Place(kind, pe, stage, index, region, view)
            size = len(self.memory_array(place))
            if not size:
                raise DebugError(f"{place.name()}: {region} is empty (size 0)")
            if not 0 <= index < size:
                raise DebugError(f"{place.name()}: address outside {region} (0..{size - 1})")
            return place
        label = reg_label(self.core(pe, stage), index) if kind == "reg" else ""
        return Place(kind, pe, stage, index, region, view, label)

    def read_word(self, place: Place) -> int:
        if place.kind == "reg":
            return self.core(place.pe, place.stage).regs[place.index]
        if place.kind == "pc":
            return self.core(place.pe, place.stage).pc
        return int(self.memory_array(place)[place.index])

    def write_word(self, place: Place, word: int) -> None:
        if place.kind == "reg":
            if place.index == 0:
                raise DebugError("r0 always reads 0; it cannot be set")
            self.core(place.pe, place.stage).regs[place.index] = word
        elif place.kind == "pc":
            core = self.core(place.pe, place.stage)
            if not 0 <= word < len(core.bundles):
                raise DebugError(f"pc {word} is outside the program (0..{len(core.bundles) - 1})")
            core.pc = word
        else:
            if place.region != "local":
                raise DebugError(f"{place.region} memory is read-only during a run "
                                 "(the host writes it); only local memory and registers can be set")
            self.memory_array(place)[place.index] = word

    def value_of(self, place: Place):
        """The place's value in its view (default: signed integer)."""
        word = self.read_word(place)
        if place.kind == "pc":
            return word
        core = self.core(place.pe, place.stage)
        if place.view == "f":
            return core.value(word, "f")
        if place.view in ("u", "x"):
            return word & core.mask
        return wrap32(word)

    def word_of(self, place: Place, value) -> int:
        """The word that stores `value` in `place` (a float is stored as a float, an integer as
        an integer; the views f and i convert, x and u take the raw bits)."""
        core = self.core(place.pe, place.stage)
        if place.kind == "pc":
            if isinstance(value, float):
                raise DebugError("a PC is an integer")
            return int(value)
        if place.view == "f" or (isinstance(value, float) and place.view == ""):
            return core.word(float(value), "f")
        if isinstance(value, float):
            raise DebugError(f"{place.name()} is an integer view; write f:{place.name()} for a float")
        if place.view in ("u", "x"):
            return int(value) & core.mask
        return core.word(int(value), "i")

    # -- expressions --------------------------------------------------------------------------

    def _resolve(self, ref: "Ref") -> Place:
        if ref.region:
            addr = self.value(ref.inner)
            if isinstance(addr, float):
                raise DebugError(f"an address is an integer, not {addr}")
            return self.make_place("mem", ref.pe, ref.stage, int(addr), ref.region, ref.view)
        if ref.reg == "pc":
            return self.make_place("pc", ref.pe, ref.stage, view=ref.view)
        return self.make_place("reg", ref.pe, ref.stage, ref.index, view=ref.view)

    def lookup(self, name: str, refs: dict):
        if name in refs:
            v = self.value_of(self._resolve(refs[name]))
            return v if isinstance(v, int) else float(v)
        if name == "cycle":
            return self.machine.cycle
        prog = self.program()
        if prog is not None:
            if name in prog.labels:
                return prog.labels[name][1]
            if name in prog.defines:
                return prog.defines[name]
        pre = predefined_symbols()
        if name in pre:
            return pre[name]
        if name in ("inf", "nan"):
            return float(name)
        raise DebugError(f"unknown name {name!r} (not a register, label or symbol of the "
                         f"{self.stage.upper()} program)")

    def with_names(self, text: str) -> str:
        """`text` with every `.reg` name (`pri`, `f:ic.pri`) replaced by its register at the
        named processor's PC, so the rest of the language sees only `rN`."""
        if not any(p is not None and p.reg_names for p in self.machine.programs.values()):
            return text

        def swap(m: re.Match) -> str:
            name = m["name"]
            if name in _RESERVED:
                return m[0]
            pe = int(m["pe"]) if m["pe"] is not None else self.pe
            stage = m["proc"] or self.stage
            prog = self.machine.programs.get(stage)
            if prog is None or not prog.reg_names or not 0 <= pe < len(self.machine.pes):
                return m[0]
            names = register_names(prog)
            if not names.known(name):
                return m[0]
            core = self.machine.pes[pe].cores[stage]
            reg = names.register(name, min(core.pc, len(prog.bundles) - 1))
            if reg is None:
                raise DebugError(f"{name!r} names different registers and none at pc "
                                 f"{core.pc}: {names.describe(name)}")
            return f"{m['q']}r{reg}"

        return _NAME.sub(swap, text)

    def value(self, text: str):
        """The value of an expression: an int or a float."""
        comp = compile_expression(self.with_names(text))
        try:
            v = evaluate(comp.tree, lambda name, loc: self.lookup(name, comp.refs))
        except ExprError as err:
            raise DebugError(err.message) from None
        except (OverflowError, ZeroDivisionError, ValueError) as err:
            raise DebugError(str(err)) from None
        if not isinstance(v, int):
            v = float(v)
        return v

    def place(self, text: str) -> Place | None:
        """The place an expression denotes if it is one reference (`r5`, `f:local[3]`), else None."""
        comp = compile_expression(self.with_names(text))
        if comp.single is None:
            return None
        return self._resolve(comp.refs[comp.single])

    def location(self, text: str) -> tuple[int | None, str, int]:
        """A code location `[peK.][os|ic|sc.]EXPR` → (pe or None for every PE, stage, address)."""
        m = _QUALIFIER.match(text)
        pe = int(m["pe"]) if m["pe"] is not None else None
        stage = m["proc"] or self.stage
        rest = m["rest"].strip()
        if rest.startswith("*"):  # gdb's spelling of an address: *12
            rest = rest[1:].strip()
        if not rest:
            raise DebugError("expected a label or an address")
        pm = re.match(r"^(os|ic|sc):(.+)$", rest, re.S)
        if pm and not m["proc"]:  # ic:loop, ic:12: --fast-forward's spelling of ic.loop
            stage, rest = pm[1], pm[2].strip().lstrip("*")
        fl = _FILE_LINE.match(rest)
        whole = _FILE_LINE.match(text.strip())
        if whole and (pe is not None or m["proc"]):  # ic.s:9 is a file before it is ic. + s:9
            try:
                found = self.source_line(whole["file"], int(whole["line"]))
                return None, found[0], found[1]
            except DebugError:
                pass
        if fl:
            found = self.source_line(fl["file"], int(fl["line"]), m["proc"])
            return pe, found[0], found[1]
        sub = Context(self.machine, self.pe if pe is None else pe, stage)
        if sub.program() is None:
            raise DebugError(f"{stage.upper()} has no program")
        addr = sub.value(rest)
        if isinstance(addr, float):
            raise DebugError(f"a code address is an integer, not {addr}")
        n = len(sub.program().bundles)
        if not 0 <= addr < n:
            raise DebugError(f"address {addr} is outside the {stage.upper()} program (0..{n - 1})")
        return pe, stage, int(addr)

    def source_line(self, file: str, line: int, stage: str | None = None) -> tuple[str, int]:
        """FILE:LINE -> (stage, address of the first bundle of that line, or of the next line
        of the file that has code, as gdb does). The file is matched by its path as the
        assembler saw it or by its name; unqualified, every program is searched (the viewed
        processor's first when several include the file)."""
        found: dict[str, list[tuple[int, int]]] = {}
        names = set()
        stages = [stage] if stage else [self.stage] + [s for s in self.machine.programs
                                                       if s != self.stage]
        for s in stages:
            prog = self.machine.programs.get(s)
            if prog is None:
                continue
            for addr in range(len(prog.bundles)):  # a scheduled bundle holds several lines
                for f, ln in bundle_lines(prog, addr):
                    names.add(f.rsplit("/", 1)[-1])
                    if same_file(f, file):
                        found.setdefault(s, []).append((ln, addr))
        if not found:
            where = f"the {stage.upper()} program" if stage else "the programs"
            known = ", ".join(sorted(names)) or "none"
            raise DebugError(f"no source file {file!r} in {where} (files: {known})")
        for s, rows in found.items():  # the viewed processor's first
            later = [r for r in rows if r[0] >= line]
            if later:
                best = min(later)
                return s, min(a for ln, a in rows if ln == best[0])
        last = max(ln for rows in found.values() for ln, _ in rows)
        raise DebugError(f"{file}:{line}: no code at or after line {line} (the last line with "
                         f"code is {last})")

    def memory_ref(self, text: str) -> Place:
        """A memory reference for `x` and `set *`: `local[E]`, `icgm E`, `local E`, or an
        expression (a data label, a number) meaning a local address."""
        text = text.strip()
        m = re.match(r"^(?:pe(\d+)\.)?(?:(os|ic|sc)\.)?(local|resident|icgm|scgm|global)\b\s*(.*)$",
                     text, re.S)
        if m and not m.group(4).startswith("["):
            pe = int(m.group(1)) if m.group(1) else None
            addr = self.value(m.group(4)) if m.group(4).strip() else 0
            if isinstance(addr, float):
                raise DebugError(f"an address is an integer, not {addr}")
            return self.make_place("mem", pe, m.group(2), int(addr), m.group(3))
        place = self.place(text)
        if place is not None and place.kind == "mem":
            return place
        addr = self.value(text)
        if isinstance(addr, float):
            raise DebugError(f"an address is an integer, not {addr}")
        return self.make_place("mem", None, None, int(addr), "local")


@dataclass(frozen=True)
class Ref:
    """A reference found in an expression, resolved to a place when evaluated."""

    view: str
    pe: int | None
    stage: str | None
    reg: str = ""
    index: int = 0
    region: str = ""
    inner: str = ""  # the address expression of a memory reference


@dataclass
class Compiled:
    tree: tuple
    refs: dict  # placeholder name -> Ref
    single: str | None  # the placeholder, when the whole expression is one reference


_CACHE: dict[str, Compiled] = {}


def compile_expression(text: str) -> Compiled:
    """Parse once (with the assembler's grammar); references become placeholder names."""
    comp = _CACHE.get(text)
    if comp is None:
        if not text.strip():
            raise DebugError("expected an expression")
        refs: dict = {}
        rewritten = _rewrite(_FLOAT_SUFFIX.sub(r"\1", text), refs)
        tree = _parse(rewritten, text)
        single = rewritten.strip() if len(refs) == 1 and rewritten.strip() in refs else None
        comp = Compiled(tree, refs, single)
        if len(_CACHE) > 512:
            _CACHE.clear()
        _CACHE[text] = comp
    return comp


def _rewrite(text: str, refs: dict) -> str:
    """Replace every register/memory/pc reference by a placeholder name."""
    out: list[str] = []
    i = 0
    while i < len(text):
        m = _REF.match(text, i)
        if m and (i == 0 or not (text[i - 1].isalnum() or text[i - 1] in "_.")):
            pe = int(m["pe"]) if m["pe"] is not None else None
            stage, view = m["proc"], m["view"] or ""
            if m["region"]:
                depth, j = 1, m.end()
                while j < len(text) and depth:
                    depth += {"[": 1, "]": -1}.get(text[j], 0)
                    j += 1
                if depth:
                    raise DebugError(f"'[' without ']' in {text.strip()!r}")
                inner = text[m.end():j - 1]
                compile_expression(inner)  # syntax errors now, not when evaluated
                ref = Ref(view, pe, stage, region=m["region"], inner=inner)
                end = j
            else:
                reg = m["reg"]
                n = REGISTER_ALIASES.get(reg, 0)
                if reg.startswith("r"):
                    n = int(reg[1:])
                    if n >= N_REGISTERS or (len(reg) > 2 and reg[1] == "0"):
                        raise DebugError(f"no register {reg} (r0..r{N_REGISTERS - 1})")
                ref = Ref(view, pe, stage, reg=reg, index=n)
                end = m.end()
            name = f"__ref{len(refs)}"
            refs[name] = ref
            out.append(f" {name} ")
            i = end
        else:
            out.append(text[i])
            i += 1
    return "".join(out)


def _parse(text: str, shown: str):
    chunk = Chunk("__expr " + text, "<expr>", 1, ["__expr " + text])
    st = parse_chunk(chunk)
    if isinstance(st, Diagnostic):
        msg = st.message.replace("syntax error: ", "")
        raise DebugError(f"bad expression {shown.strip()!r}: {msg}")
    item = st.item
    if st.labels or not isinstance(item, Instr) or len(item.operands) != 1 \
            or item.operands[0].kind != "expr":
        raise DebugError(f"bad expression {shown.strip()!r}")
    return item.operands[0].expr


def format_number(v) -> str:
    """An int, or a float in its shortest form (numpy prints a float32 as a float32)."""
    return str(v)


def format_word(core, word: int) -> str:
    """A raw word in every view: '3  (0x00000003, float 4.2e-45)'."""
    digits = 2 * (core.mask.bit_length() // 8)
    return f"{wrap32(word)}  (0x{word & core.mask:0{digits}x}, float {str(core.value(word, 'f'))})"


def looks_float(core, word: int) -> bool:
    """A guess for display only: a normal float that is not a small integer, or an infinity."""
    w = word & core.mask
    if core.mask == 0xFFFFFFFF:
        exp, small = (w >> 23) & 0xFF, abs(wrap32(w)) < (1 << 20)
        return (0 < exp < 0xFF and not small) or w & 0x7FFFFFFF == 0x7F800000
    exp = (w >> 52) & 0x7FF
    return (0 < exp < 0x7FF and not (w < (1 << 20) or w > core.mask - (1 << 20))) \
        or w & 0x7FFFFFFFFFFFFFFF == 0x7FF0000000000000


def short_word(core, word: int) -> str:
    """An integer, with its float view when the word looks like a float: '1065353216 (1.0)'."""
    text = str(wrap32(word))
    if looks_float(core, word):
        text += f" ({str(core.value(word, 'f'))})"
    return text


def hex_word(core, word: int) -> str:
    digits = 2 * (core.mask.bit_length() // 8)
    return f"0x{word & core.mask:0{digits}x}"


__all__ = ["Context", "DebugError", "Place", "REGIONS", "VIEWS", "compile_expression",
           "format_number", "format_word", "hex_word", "short_word"]
