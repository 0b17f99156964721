"""A program's result: the registers and memory words a run leaves behind.

`netsushisen run --regs` and `--mem PROC.MEMORY:ADDR[:N[F]]` print them after the summary, and
`run --json` carries them as its `final` section, so a kernel writer sees a dot product's sum
without the debugger (as Spike's `+signature` or RARS's register window at exit show a
program's result). Everything is read through the engine interface (emulator/engine.py), whose
engines all write their state back into the reference objects: every engine gives the same text
and the same JSON.

A register is shown when it is non-zero or a `.reg` names it, as `name/rN` (the name in force
at the processor's last pc, else the latest defined), with its word as a signed integer, in hex
and as a float of the machine's precision. A memory request's words are shown in the
debugger's `x` formats (x d u f, or a: all three views, the default).
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass

from netsushisen.asm.objects import Program
from netsushisen.asm.regnames import register_names
from netsushisen.isa.errors import NetsushisenError
from netsushisen.isa.processors import STAGES, register_name
from netsushisen.isa.words import WordFormat, word_format, wrap32

SPACES = ("local", "resident", "global")
FORMATS = "xdufa"

_REQUEST = re.compile(r"^(?:(pe\d+)\.)?([a-z]+)\.([a-z]+):([^:]+)(?::(\d*)([a-z]?))?$")


@dataclass(frozen=True)
class MemoryRequest:
    """What one `--mem` asks for: `count` words of `processor`'s `space` from `address`, shown
    in format `fmt`; `text` is the request as written (the JSON's key)."""

    text: str
    processor: str
    space: str
    address: int | str
    count: int
    fmt: str


def parse_memory_request(text: str) -> MemoryRequest:
    """`[peN.]PROC.MEMORY:ADDR[:N[F]]` (ADDR a number or a data label of PROC's program; N
    words, default 1; F a format of x d u f a, default a), or a one-line error naming the
    form."""
    m = _REQUEST.match(text.strip())
    form = ("expected [peN.]PROC.MEMORY:ADDR[:N[F]], e.g. ic.local:0:4 or ic.resident:16:8f "
            f"(MEMORY {', '.join(SPACES)}; F one of {', '.join(FORMATS)})")
    if m is None:
        raise NetsushisenError(f"--mem {text!r}: {form}")
    pe, stage, space, addr, count, fmt = m.groups()
    if stage not in STAGES or space not in SPACES or (fmt and fmt not in FORMATS):
        raise NetsushisenError(f"--mem {text!r}: {form}")
    try:
        address: int | str = int(addr, 0)
    except ValueError:
        if not addr.isidentifier():
            raise NetsushisenError(f"--mem {text!r}: ADDR must be a number or a data label") \
                from None
        address = addr
    if isinstance(address, int) and address < 0:
        raise NetsushisenError(f"--mem {text!r}: ADDR must not be negative")
    return MemoryRequest(text, f"{pe or 'pe0'}.{stage}", space, address,
                         int(count) if count else 1, fmt or "a")


@dataclass(frozen=True)
class FinalRegister:
    """One register a run left: its number, its `.reg` name (None: none) and raw word."""

    reg: int
    name: str | None
    word: int

    @property
    def label(self) -> str:
        return f"{self.name}/{register_name(self.reg)}" if self.name else register_name(self.reg)


def word_views(wf: WordFormat, word: int) -> dict:
    """A word as JSON: its signed integer, hex and float (a non-finite float as a string)."""
    value = float(str(wf.to_float(word)))  # the shortest text of the machine's float
    return {"int": wrap32(word), "hex": f"0x{word & wf.mask:0{2 * wf.bytes}x}",
            "float": value if math.isfinite(value) else str(value)}


def format_word(wf: WordFormat, word: int, fmt: str) -> str:
    """A word in a debugger `x` format: x (hex), d (signed), u (unsigned), f (float), a (all)."""
    views = word_views(wf, word)
    if fmt == "x":
        return views["hex"]
    if fmt == "d":
        return str(views["int"])
    if fmt == "u":
        return str(word & wf.mask)
    if fmt == "f":
        return str(wf.to_float(word))
    return f"{views['hex']}  {views['int']:>11}  {wf.to_float(word)}"


def _names(program: Program, pc: int) -> dict[int, str]:
    """Register -> its `.reg` name at `pc` (the one in force there, else the latest defined)."""
    names = {s.reg: s.name for s in program.reg_names}
    names.update(register_names(program).names(pc))
    return names


def final_registers(engine, programs: dict[str, Program | None]) -> dict[str, list[FinalRegister]]:
    """Per processor with a program, in machine order: its registers that are non-zero or
    named by a `.reg`."""
    out: dict[str, list[FinalRegister]] = {}
    for processor in engine.processors():
        program = programs.get(processor.split(".")[1])
        if program is None:
            continue
        names = _names(program, engine.pc(processor))
        out[processor] = [FinalRegister(r, names.get(r), w)
                          for r, w in enumerate(engine.registers(processor))
                          if r and (w or r in names)]
    return out


def read_memory(engine, programs: dict[str, Program | None],
                request: MemoryRequest) -> tuple[int, list[int]]:
    """(address, words) of a request, or a one-line error: no such processor or memory, a data
    label its program lacks, an address past the memory's end (a range running past the end is
    cut there)."""
    where = f"--mem {request.text!r}"
    if request.processor not in engine.processors():
        raise NetsushisenError(f"{where}: no processor {request.processor} (have "
                               f"{', '.join(engine.processors())})")
    address = request.address
    if isinstance(address, str):
        program = programs.get(request.processor.split(".")[1])
        label = program.labels.get(address) if program is not None else None
        if label is None or label[0] != "data":
            raise NetsushisenError(f"{where}: no data label {address!r} in "
                                   f"{request.processor}'s program")
        address = label[1]
    try:
        words = engine.memory(request.processor, request.space)
    except KeyError as err:
        raise NetsushisenError(f"{where}: {err.args[0]}") from None
    if address >= len(words):
        raise NetsushisenError(f"{where}: address {address} is past the memory's end "
                               f"({len(words)} words)")
    return address, [int(w) for w in words[address:address + request.count]]


@dataclass
class FinalState:
    """What `run --regs` / `--mem` show and `run --json`'s `final` holds."""

    wf: WordFormat
    registers: dict[str, list[FinalRegister]]
    memory: list[tuple[MemoryRequest, int, list[int]]]

    def json(self) -> dict:
        return {
            "registers": {p: [{"reg": register_name(r.reg), "name": r.name,
                               **word_views(self.wf, r.word)} for r in regs]
                          for p, regs in self.registers.items()},
            "memory": [{"request": req.text, "processor": req.processor, "space": req.space,
                        "address": address, "words": [word_views(self.wf, w) for w in words]}
                       for req, address, words in self.memory],
        }

    def registers_text(self) -> str:
        lines = []
        for processor, regs in self.registers.items():
            lines.append(f"{processor} registers:" + (f"  {'int':>11}  {'hex':10s}  float"
                                                     if regs else " all zero"))
            for r in regs:
                v = word_views(self.wf, r.word)
                lines.append(f"  {r.label:<16} {v['int']:>11}  {v['hex']}  "
                             f"{self.wf.to_float(r.word)}")
        return "\n".join(lines)

    def memory_text(self) -> str:
        lines = []
        for req, address, words in self.memory:
            short = f"{req.processor.removeprefix('pe0.')}.{req.space}"
            per = 1 if req.fmt == "a" else 4
            for k in range(0, len(words), per):
                cells = [format_word(self.wf, w, req.fmt) for w in words[k:k + per]]
                lines.append(f"{short}[{address + k}]:  "
                             + "  ".join(c if req.fmt == "a" else c.rjust(12) for c in cells))
            if len(words) < req.count:
                lines.append(f"({short} ends at {address + len(words) - 1})")
        return "\n".join(lines)


def final_state(engine, programs: dict[str, Program | None],
                requests: list[MemoryRequest]) -> FinalState:
    """The registers of every processor with a program and the words of each request."""
    memory = [(req, *read_memory(engine, programs, req)) for req in requests]
    return FinalState(word_format(engine.config.precision), final_registers(engine, programs),
                      memory)
