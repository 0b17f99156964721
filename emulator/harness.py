"""Run one stage kernel alone: the test bench the kernel writers share.

A stage program is exercised with real ring traffic: the other two processors run tiny stubs.
When OS is not the stage under test, its stub forwards the host stream word by word into the
ring (so the host stream can hold messages for IC or SC: the CMU routes them by their headers)
and stores every word that reaches OS into its local memory; IC and SC stubs store what reaches
them. After the run the stored words come back split into messages per stage. Everything goes
through the machine's real CMUs, FIFOs and timing.

The bench builds its machine through the engine interface (emulator/engine.py) and reads the run
back only through it, so every bench test runs unchanged on any engine (`engine=`). The same holds
for `run_machine`, the whole-machine runner the emulator tests share, and `ProcessorView`, their
shorthand for one processor's counters and registers.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from netsushisen.asm.assembler import assemble_text
from netsushisen.asm.objects import Program
from netsushisen.emulator.engine import Engine, default_engine, make_engine
from netsushisen.emulator.machine import RunResult
from netsushisen.isa.config import MachineConfig
from netsushisen.isa.images import MemoryImage, Segment
from netsushisen.isa.processors import STAGES
from netsushisen.isa.ring import DESTS, make_header, parse_header
from netsushisen.isa.words import WordFormat, word_format, wrap32

SINK_REGISTER = 60  # the stubs count stored words here

_SINK = f"""
        li r{SINK_REGISTER}, 0
loop:   recv r1, ring
        st r1, [r{SINK_REGISTER}]
        addi r{SINK_REGISTER}, r{SINK_REGISTER}, 1
        j loop
"""
_OS_SOURCE_SINK = f"""
# Drain the ring before forwarding the next host word: a stub that blocks in `send` while its
# own receive FIFO is full would deadlock the ring (the answers could never be consumed).
        li r{SINK_REGISTER}, 0
loop:   wait
        poll r1, ring
        beqz r1, forward
        recv r2, ring
        st r2, [r{SINK_REGISTER}]
        addi r{SINK_REGISTER}, r{SINK_REGISTER}, 1
        j loop
forward:
        recv r2, host
        send ring, r2
        j loop
"""


def encode_message(wf: WordFormat, dest: str, tag: int, fields: list, cls: int = 0) -> list[int]:
    """Header + payload words: Python/numpy ints become integer words, floats float words."""
    words = [wf.from_int(make_header(len(fields), DESTS[dest], cls, tag))]
    for v in fields:
        if isinstance(v, (float, np.floating)):
            words.append(wf.from_float(v))
        else:
            words.append(wf.from_int(int(v)))
    return words


def split_words(words: list[int]) -> list[list[int]]:
    """A stored word stream as messages (header + payload); a cut-off tail is kept as is."""
    out, i = [], 0
    while i < len(words):
        n = parse_header(words[i]).length
        out.append(words[i:i + 1 + n])
        i += 1 + n
    return out


def run_machine(engine: str, config: MachineConfig, programs: dict[str, Program | None],
                image: MemoryImage | None = None, max_cycles: int | None = None) -> Engine:
    """Build engine `engine` for (config, programs, image) and run it to its end or `max_cycles`;
    the run's result is `.result()`, everything else is read through the interface."""
    e = make_engine(engine or default_engine(), config, programs, image)
    e.run(max_cycles)
    return e


class ProcessorView:
    """One processor after a run, read through the engine interface: its statistics
    (`cycles`, `bundles`, `stalls`, `stalls_by_pc` keyed by int pc, the whole entry as `stats`)
    and its registers (`raw(r)`, `int(r)`, `float(r)` in the machine's precision)."""

    def __init__(self, engine: Engine, processor: str, statistics: dict | None = None):
        s = (statistics or engine.statistics())["processors"][processor]
        self.name = processor
        self.stats = s
        self.cycles: int = s["cycles"]
        self.bundles: int = s["bundles"]
        self.stalls: dict[str, int] = s["stalls"]
        self.stalls_by_pc = {int(pc): e["stalls"] for pc, e in s["stalls_by_pc"].items()}
        self.regs = engine.registers(processor)
        self.wf = word_format(engine.config.precision)

    def raw(self, r: int) -> int:
        return self.regs[r]

    def int(self, r: int) -> int:
        return self.wf.to_int(self.regs[r])

    def float(self, r: int):
        return self.wf.to_float(self.regs[r])


@dataclass
class StageRun:
    result: RunResult
    engine: Engine
    received: dict[str, list[list[int]]] = field(default_factory=dict)
    """Messages that reached each stubbed stage, in arrival order."""

    @property
    def frame(self) -> np.ndarray:
        return self.engine.frame

    @property
    def ids(self) -> np.ndarray:
        return self.engine.ids

    def statistics(self) -> dict:
        return self.engine.statistics()

    def processor(self, stage: str) -> ProcessorView:
        """The stage's processor of PE 0 (the one the bench runs)."""
        return ProcessorView(self.engine, f"pe0.{stage}")

    def memory(self, stage: str, space: str = "local") -> np.ndarray:
        """Raw words of PE 0's `stage` memory `space` (local, resident, global)."""
        return self.engine.memory(f"pe0.{stage}", space)


def run_stage(stage: str, program: Program, host_messages: list[list[int]], config: MachineConfig,
              image: MemoryImage | None = None, max_cycles: int = 2_000_000,
              engine: str | None = None) -> StageRun:
    """Run `program` on `stage` of PE 0 with stubs elsewhere, on engine `engine`;
    `host_messages` (raw words, e.g. from `encode_message`) are the host stream."""
    if program.proc != stage:
        raise ValueError(f"a {program.proc.upper()} program cannot run on {stage.upper()}")
    programs = {s: assemble_text(_OS_SOURCE_SINK if s == "os" else _SINK, proc=s,
                                 filename=f"<{s} stub>") for s in STAGES}
    programs[stage] = program
    image = image or MemoryImage()
    image.host = [Segment(0, [("w", np.asarray([w for m in host_messages for w in m], dtype=np.uint64))])]
    e = make_engine(engine or default_engine(), config, programs, image)
    result = e.run(max_cycles)
    received = {}
    for s in STAGES:
        if s == stage:
            continue
        n = wrap32(e.register(f"pe0.{s}", SINK_REGISTER))
        words = [int(w) for w in e.memory(f"pe0.{s}", "local")[:n]]
        received[s] = split_words(words)
    return StageRun(result, e, received)
