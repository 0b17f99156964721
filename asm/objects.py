"""Assembled programs and the object file format.

A `Program` is what the assembler produces and what the disassembler, the emulator engines and
the debugger consume: the processor it is for, its bundles (each a tuple of `Op`s issued in one
cycle; SC bundles hold one op), its local data words, its labels and a source map (one location
per bundle) for listings, traces and the debugger.

Object files are JSON (`netsushisen-object`, versioned): readable, diffable, and exact — integers
are 32-bit values, floats are stored as doubles written by `repr` so they round-trip bit for bit.
"""

from __future__ import annotations

import json
import math
import re
from dataclasses import dataclass, field
from functools import lru_cache
from pathlib import Path
from typing import Any, Union

from netsushisen.isa.errors import Diagnostic, NetsushisenError
from netsushisen.isa.opcodes import OPCODES, Opcode
from netsushisen.isa.processors import PROCESSORS, ZERO_REGISTER, register_name

OBJECT_FORMAT = "netsushisen-object"
OBJECT_VERSION = 1

Arg = Union[int, float, str, tuple[int, int]]
"""An operand value: register index or integer (rd, rs, imm, label), float (fimm), port name,
or (base register, offset) for a memory operand."""


@dataclass(frozen=True)
class Op:
    mnemonic: str
    args: tuple[Arg, ...] = ()

    @property
    def opcode(self) -> Opcode:
        return OPCODES[self.mnemonic]

    def reads(self) -> tuple[int, ...]:
        """Registers this op reads at issue (r0 excluded: it is a constant, not a port read)."""
        return _reads(self.mnemonic, self.args)

    def writes(self) -> tuple[int, ...]:
        """Registers this op writes (r0 excluded: writes to it are discarded)."""
        return _writes(self.mnemonic, self.args)

    def format(self, code_labels: dict[int, str] | None = None, reg_names: dict[int, str] | None = None) -> str:
        """Assembly text of this op; branch targets shown as labels where one names the address."""
        parts = []
        for operand, arg in zip(self.opcode.operands, self.args):
            parts.append(format_arg(operand.kind, arg, code_labels, reg_names))
        return f"{self.mnemonic} {', '.join(parts)}".rstrip()


# An op's register reads and writes depend on its mnemonic and operands only (Op is frozen); the
# schedulers ask for them tens of thousands of times per kernel, so they are computed once.
@lru_cache(maxsize=1 << 16)
def _reads(mnemonic: str, args: tuple) -> tuple[int, ...]:
    opcode = OPCODES[mnemonic]
    regs = []
    for operand, arg in zip(opcode.operands, args):
        if operand.kind == "rs":
            regs.append(arg)
        elif operand.kind == "mem":
            regs.append(arg[0])
    regs.extend(opcode.implicit_reads)
    return tuple(r for r in regs if r != ZERO_REGISTER)


@lru_cache(maxsize=1 << 16)
def _writes(mnemonic: str, args: tuple) -> tuple[int, ...]:
    opcode = OPCODES[mnemonic]
    regs = [arg for operand, arg in zip(opcode.operands, args) if operand.kind == "rd"]
    regs.extend(opcode.implicit_writes)
    return tuple(r for r in regs if r != ZERO_REGISTER)


def format_float(x: float) -> str:
    """A float literal the assembler reads back to the identical double."""
    if math.isnan(x):
        return "nan"
    if math.isinf(x):
        return "inf" if x > 0 else "-inf"
    text = repr(float(x))
    return text


def format_arg(kind: str, arg: Arg, code_labels: dict[int, str] | None = None,
               reg_names: dict[int, str] | None = None) -> str:
    def reg(r: int) -> str:
        return (reg_names or {}).get(r) or register_name(r)

    if kind in ("rd", "rs"):
        return reg(arg)
    if kind == "mem":
        base, offset = arg
        if base == ZERO_REGISTER:
            return f"[{offset}]"
        if offset == 0:
            return f"[{reg(base)}]"
        return f"[{reg(base)} + {offset}]" if offset > 0 else f"[{reg(base)} - {-offset}]"
    if kind == "fimm":
        return format_float(arg)
    if kind == "label":
        if code_labels and arg in code_labels:
            return code_labels[arg]
        return str(arg)
    return str(arg)


@dataclass(frozen=True)
class SourceLoc:
    file: str
    line: int
    text: str = ""
    via: str = ""
    """The macro / .rept expansions the bundle came from (`file:line: invocation`, outermost
    first, joined by ` > `); "" for a bundle written out."""


_INT32 = range(-(1 << 31), 1 << 31)
_NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_.$]*\Z")


def _problem(proc: str, bundles: list, data: list, labels: dict, defines: dict) -> str | None:
    """What makes a decoded object impossible for its processor, or None: the checks the
    assembler made (registers, immediates and offsets to their 32-bit fields, branch targets
    inside the program, ports the processor has, opcodes it runs, names that are names), so
    that a hand-edited object cannot run differently on the two engines."""
    processor = PROCESSORS[proc]
    for i, bundle in enumerate(bundles):
        for op in bundle:
            opcode = op.opcode
            if proc not in opcode.procs:
                return f"bundle {i}: {op.mnemonic} does not run on {proc.upper()}"
            for spec, a in zip(opcode.operands, op.args):
                if spec.kind in ("rd", "rs") and not 0 <= a < processor.registers:
                    return f"bundle {i}: {op.mnemonic}: register {a} (registers are r0..r{processor.registers - 1})"
                if spec.kind == "mem" and (not 0 <= a[0] < processor.registers or a[1] not in _INT32):
                    return f"bundle {i}: {op.mnemonic}: memory operand {list(a)} (a register and a 32-bit offset)"
                if spec.kind == "imm" and a not in _INT32:
                    return f"bundle {i}: {op.mnemonic}: immediate {a} does not fit its 32-bit field"
                if spec.kind == "label" and not 0 <= a < len(bundles):
                    return f"bundle {i}: {op.mnemonic}: branch target {a} outside the program (0..{len(bundles) - 1})"
                if spec.kind == "port":
                    ports = processor.send_ports if opcode.sends_to_port else processor.recv_ports
                    if a not in ports:
                        return f"bundle {i}: {op.mnemonic}: port {a!r} ({proc.upper()} has {', '.join(ports)})"
    for k, v in data:
        if k not in ("i", "f") or (k == "i" and v not in _INT32):
            return f"data word {k!r} {v!r} (a 32-bit integer 'i' or a float 'f')"
    for name, (section, at) in labels.items():
        size = len(bundles) if section == "text" else len(data)
        if not _NAME.match(name) or section not in ("text", "data") or not 0 <= at <= size:
            return f"label {name!r} at {section} {at}"
    for name, v in defines.items():
        if not _NAME.match(name) or isinstance(v, bool) or not isinstance(v, (int, float)):
            return f"define {name!r} = {v!r}"
    return None


@dataclass(frozen=True)
class RegName:
    """A `.reg` name in force over bundles `start..end-1` (the assembler resolves a name to the
    register of its latest `.reg` before the bundle, so a redefinition ends the scope)."""

    name: str
    reg: int
    start: int
    end: int


@dataclass
class Program:
    proc: str
    bundles: list[tuple[Op, ...]]
    data: list[tuple[str, int | float]] = field(default_factory=list)
    """Local data words from `.word`/`.float`/`.space`: ('i', int) or ('f', float), loaded at
    local address 0 upward."""
    labels: dict[str, tuple[str, int]] = field(default_factory=dict)
    """name -> ('text', bundle address) or ('data', local word address)."""
    source_map: list[SourceLoc] = field(default_factory=list)
    defines: dict[str, int | float] = field(default_factory=dict)
    """The -D symbols the program was assembled with (a specialised kernel records its scene's needs)."""
    op_sources: list[tuple[SourceLoc, ...]] = field(default_factory=list)
    """Per bundle, one location per operation in the bundle's order (a scheduled `.sched` bundle
    gathers operations of several source lines); empty when unknown (an older object file)."""
    reg_names: list[RegName] = field(default_factory=list)
    """The `.reg` names by scope, in definition order (asm/regnames.py reads them); an
    optional key of the object file (`reg_names`), absent in files from before it."""

    @property
    def processor(self):
        return PROCESSORS[self.proc]

    def code_labels(self) -> dict[int, str]:
        """Bundle address -> first label naming it (alphabetical among equals, for determinism)."""
        out: dict[int, str] = {}
        for name, (section, addr) in sorted(self.labels.items()):
            if section == "text" and addr not in out:
                out[addr] = name
        return out

    def label_at(self, address: int) -> str:
        """'label+offset' for a code address: the nearest label at or before it."""
        best = None
        for name, (section, addr) in sorted(self.labels.items()):
            if section == "text" and addr <= address and (best is None or addr > best[1]):
                best = (name, addr)
        if best is None:
            return str(address)
        return best[0] if best[1] == address else f"{best[0]}+{address - best[1]}"

    def same_program(self, other: "Program") -> bool:
        """Identical machine program: processor, bundles, data and labels (source map aside)."""
        return (self.proc == other.proc and _bundles_key(self.bundles) == _bundles_key(other.bundles)
                and _data_key(self.data) == _data_key(other.data) and self.labels == other.labels)

    # -- object files -------------------------------------------------------------------------

    def to_json(self) -> dict[str, Any]:
        return {
            "format": OBJECT_FORMAT,
            "version": OBJECT_VERSION,
            "proc": self.proc,
            "bundles": [[[op.mnemonic, *[list(a) if isinstance(a, tuple) else a for a in op.args]]
                         for op in bundle] for bundle in self.bundles],
            "data": [[k, v] for k, v in self.data],
            "labels": {name: [sec, addr] for name, (sec, addr) in sorted(self.labels.items())},
            "source_map": [[s.file, s.line, s.text, *([s.via] if s.via else [])]
                           for s in self.source_map],
            "defines": dict(sorted(self.defines.items())),
            **({"op_sources": [[[s.file, s.line, s.text, *([s.via] if s.via else [])] for s in ops]
                               for ops in self.op_sources]} if self.op_sources else {}),
            **({"reg_names": [[r.name, r.reg, r.start, r.end] for r in self.reg_names]}
               if self.reg_names else {}),
        }

    def save(self, path: str | Path) -> None:
        from netsushisen.isa.outputs import write_text

        write_text(path, json.dumps(self.to_json(), indent=None, separators=(",", ":")) + "\n")

    @classmethod
    def from_json(cls, obj: dict[str, Any], where: str = "<object>") -> "Program":
        def bad(msg: str) -> NetsushisenError:
            return NetsushisenError(Diagnostic(f"bad object file: {msg}", file=where))

        if not isinstance(obj, dict) or obj.get("format") != OBJECT_FORMAT:
            raise bad(f"not a {OBJECT_FORMAT} file")
        if obj.get("version") != OBJECT_VERSION or isinstance(obj.get("version"), bool):
            raise bad(f"version {obj.get('version')!r} is not {OBJECT_VERSION}")
        proc = obj.get("proc")
        if not isinstance(proc, str) or proc not in PROCESSORS:
            raise bad(f"unknown processor {proc!r}")
        try:
            bundles = []
            for i, raw in enumerate(obj["bundles"]):
                ops = []
                for item in raw:
                    mnemonic, *args = item
                    if not isinstance(mnemonic, str) or mnemonic not in OPCODES:
                        raise bad(f"bundle {i}: unknown mnemonic {mnemonic!r}")
                    opcode = OPCODES[mnemonic]
                    if len(args) != len(opcode.operands):
                        raise bad(f"bundle {i}: {mnemonic} takes {len(opcode.operands)} operands")
                    conv = []
                    for operand, a in zip(opcode.operands, args):
                        if operand.kind == "mem":
                            conv.append((int(a[0]), int(a[1])))
                        elif operand.kind == "fimm":
                            conv.append(float(a))
                        elif operand.kind == "port":
                            conv.append(str(a))
                        else:
                            conv.append(int(a))
                    ops.append(Op(mnemonic, tuple(conv)))
                bundles.append(tuple(ops))
            data = [(str(k), float(v) if k == "f" else int(v)) for k, v in obj.get("data", [])]
            labels = {str(n): (str(s), int(a)) for n, (s, a) in obj.get("labels", {}).items()}
            smap = [SourceLoc(str(f), int(l), str(t), *[str(v) for v in via])
                    for f, l, t, *via in obj.get("source_map", [])]
            defines = dict(obj.get("defines", {}))
            op_sources = [tuple(SourceLoc(str(f), int(l), str(t), *[str(v) for v in via])
                                for f, l, t, *via in ops) for ops in obj.get("op_sources", [])]
            reg_names = [RegName(str(n), int(r), int(a), int(b))
                         for n, r, a, b in obj.get("reg_names", [])]
        except NetsushisenError:
            raise
        except (KeyError, TypeError, ValueError, IndexError, OverflowError, AttributeError) as err:
            raise bad(f"malformed content ({type(err).__name__}: {err})") from None
        problem = _problem(proc, bundles, data, labels, defines)
        if problem:
            raise bad(problem)
        return cls(proc, bundles, data, labels, smap, defines, op_sources, reg_names)

    @classmethod
    def load(cls, path: str | Path) -> "Program":
        p = Path(path)
        try:
            from netsushisen.isa.limits import read_input

            from netsushisen.isa import numbers

            text = read_input(p, "object file").decode("utf-8")
            obj = numbers.loads(text, finite=False)  # `.float nan` data is a word like any
        except (FileNotFoundError, IsADirectoryError):
            raise NetsushisenError(Diagnostic("no such object file", file=str(p))) from None
        except (UnicodeDecodeError, json.JSONDecodeError, RecursionError):
            raise NetsushisenError(Diagnostic(
                f"not a {OBJECT_FORMAT} file (assemble the source with `netsushisen asm`)",
                file=str(p))) from None
        bad = numbers.first_problem(obj, finite=False)
        if bad:
            raise NetsushisenError(Diagnostic(f"bad object file: {bad[0]}: {bad[1]}", file=str(p)))
        return cls.from_json(obj, str(p))


def _data_key(data: list[tuple[str, int | float]]) -> list:
    """Data compared bit-exactly (NaN == NaN, -0.0 != 0.0)."""
    out = []
    for k, v in data:
        out.append((k, repr(float(v)) if k == "f" else v))
    return out


def _bundles_key(bundles: list[tuple[Op, ...]]) -> list:
    """Bundles compared bit-exactly: float immediates by repr (so NaN equals NaN)."""
    return [tuple((op.mnemonic, tuple(repr(a) if isinstance(a, float) else a for a in op.args))
                  for op in bundle) for bundle in bundles]
