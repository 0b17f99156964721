"""Run statistics: one JSON object per run, deterministic (no wall time; sorted keys).

Schema `netsushisen-stats` version 1:

    schema       {"name": "netsushisen-stats", "version": 1}
    config       the full MachineConfig (a run is reproducible from its statistics)
    programs     per stage: bundles, data words, source file, defines (or null when absent);
                 static_ilp (ops per bundle, slot fill per unit class, register-port use of
                 the program as scheduled: `asm.listing.static_ilp`); listing: columns
                 indexed by bundle address — label (label+offset), text (its ops, `; `-joined,
                 or `nop`), ops, target (the code address a branch or jump names, else null),
                 source ("file:line") — what `report annotate` prints the per-PC counters
                 against, without the source files
    run          status (halted/finished/deadlock/fault/max_cycles, or interrupted: stopped by
                 Ctrl-C, the counters so far), cycles, message,
                 left_in_flight (words still in FIFOs at the end), engine (the engine that
                 ran: reference, compiled or tandem — set by the engine interface, the one
                 field in which two engines' statistics differ)
    processors   keyed "pe0.os", "pe0.ic", "pe0.sc", "pe1.os", ...: present, halted, pc,
                 cycles, bundles, ops, ops_by_unit, ops_by_mnemonic, stalls {cause: cycles},
                 stall_cycles, stalls_by_pc {"pc": {label, stalls {cause: cycles}}}
                 (invariant: cycles == bundles + stall_cycles)
    memory       keyed the same way: local {reads, writes, words}; IC/SC also resident
                 {accesses, words}, cache {accesses, hits, misses, sets, block_bytes}, global
                 {accesses}; `regions` {"<space>.<name>": {accesses[, hits, misses]}} and
                 `primitives` {id: references} when the image gives region maps
    global_memory  ICGM/SCGM sizes in words
    fifos        keyed by FIFO name ("pe0.send.os", "pe0.link.os-ic.3", ...): capacity, peak,
                 words (ever pushed), left (at the end); buffer-pool channels never used are
                 omitted
    dis          messages, words, per-PE messages; col: pixel messages, words
"""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np

from netsushisen.asm.listing import bundle_target, static_ilp, target_names
from netsushisen.asm.objects import Program
from netsushisen.emulator.machine import Machine

SCHEMA = {"name": "netsushisen-stats", "version": 1}


def program_listing(program: Program) -> dict[str, list]:
    """Per bundle address, as columns (a list each, compact in the indented JSON): its
    label+offset, text, operation count, the code address a branch or jump names (`report
    annotate` finds loops from the backward ones), the source line and the source lines of its
    operations (`lines`: "ic.s:12, 13" — a scheduled bundle gathers several). The statistics carry it
    so a report reads the program beside its counters even when the kernel source has changed
    or is gone; the file name alone keeps the statistics the same wherever the kernels are."""
    labels = program.code_labels()
    names = target_names(program)  # one pass: label+offset of every address
    out: dict[str, list] = {"label": [], "text": [], "ops": [], "target": [], "source": [],
                            "lines": []}
    for addr, bundle in enumerate(program.bundles):
        real = [op for op in bundle if op.opcode.kind != "nop"]
        loc = program.source_map[addr] if addr < len(program.source_map) else None
        out["label"].append(names.get(addr, str(addr)))
        out["text"].append(" ; ".join(op.format(labels) for op in real) or "nop")
        out["ops"].append(len(real))
        out["target"].append(bundle_target(bundle))
        out["source"].append(f"{os.path.basename(loc.file)}:{loc.line}" if loc else None)
        out["lines"].append(source_lines(program, addr))
    return out


def source_lines(program: Program, addr: int) -> str | None:
    """The distinct source lines of a bundle's operations, "file:line, line, other:line"."""
    if addr >= len(program.op_sources) or not program.op_sources[addr]:
        return None
    parts, seen, last_file = [], set(), None
    for s in program.op_sources[addr]:
        if (s.file, s.line) in seen:
            continue
        seen.add((s.file, s.line))
        name = os.path.basename(s.file)
        parts.append(str(s.line) if name == last_file else f"{name}:{s.line}")
        last_file = name
    return ", ".join(parts)


def collect(machine: Machine) -> dict:
    programs = {}
    for stage, p in machine.programs.items():
        programs[stage] = None if p is None else {
            "bundles": len(p.bundles), "data_words": len(p.data),
            "source": p.source_map[0].file if p.source_map else None,
            "defines": {k: v for k, v in sorted(p.defines.items())},
            "static_ilp": static_ilp(p).as_dict(),
            "listing": program_listing(p)}
    processors, memory, fifos = {}, {}, {}
    left = 0
    for pe in machine.pes:
        for stage, core in pe.cores.items():
            processors[core.name] = core.stats()
            memory[core.name] = pe.memories[stage].stats()
        for f in pe.ring.fifos():
            left += len(f)
            if f.total == 0 and machine.config.ring.buffer_pool and ".link." in f.name:
                continue
            fifos[f.name] = {"capacity": f.capacity, "peak": f.peak, "words": f.total,
                             "left": len(f)}
    err = machine.error
    return {
        "schema": SCHEMA,
        "config": machine.config.to_dict(),
        "programs": programs,
        "run": {"status": machine.status, "cycles": machine.cycle,
                "message": err.format() if err is not None else None,
                "left_in_flight": left},
        "processors": processors,
        "memory": memory,
        "global_memory": {g.name.lower(): {"words": g.size} for g in machine.globals.values()},
        "fifos": fifos,
        "dis": {"messages": len(machine.dis.messages), "words": machine.dis.words_sent,
                "messages_per_pe": list(machine.dis.assigned)},
        "col": {"pixel_messages": machine.col.messages, "words": machine.col.words},
    }


def without_engine(stats: dict) -> dict:
    """The statistics with `run.engine` left out: what two engines' runs of one machine must
    give alike, byte for byte (the engine's name is the one field that differs by design)."""
    return stats | {"run": {k: v for k, v in stats["run"].items() if k != "engine"}}


def dumps(stats: dict) -> str:
    return json.dumps(stats, sort_keys=True, indent=1, allow_nan=False) + "\n"


def write(machine: Machine, path: str | Path) -> None:
    from netsushisen.isa.outputs import write_text

    write_text(path, dumps(collect(machine)))


def ic_reference_counts(stats: dict, n_primitives: int) -> np.ndarray:
    """Per-primitive IC references (tests of each primitive) summed over the PEs' ICs: what the
    golden model's `references` counts."""
    refs = np.zeros(n_primitives, np.int64)
    for name, mem in stats["memory"].items():
        if name.endswith(".ic"):
            for prim, count in mem.get("primitives", {}).items():
                refs[int(prim)] += count
    return refs
