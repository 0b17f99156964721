"""Run one stage kernel alone: the test bench the kernel writers share.

A stage program is exercised with real ring traffic: the other two processors run tiny stubs.
When OS is not the stage under test, its stub forwards the host stream word by word into the
ring (so the host stream can hold messages for IC or SC: the CMU routes them by their headers)
and stores every word that reaches OS into its local memory; IC and SC stubs store what reaches
them. After the run the stored words come back split into messages per stage. Everything goes
through the machine's real CMUs, FIFOs and timing.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from netsushisen.asm.assembler import assemble_text
from netsushisen.asm.objects import Program
from netsushisen.isa.images import MemoryImage, Segment
from netsushisen.emulator.machine import Machine, RunResult
from netsushisen.isa.config import MachineConfig
from netsushisen.isa.processors import STAGES
from netsushisen.isa.ring import DESTS, make_header, parse_header
from netsushisen.isa.words import WordFormat, wrap32

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


@dataclass
class StageRun:
    result: RunResult
    machine: Machine
    received: dict[str, list[list[int]]] = field(default_factory=dict)
    """Messages that reached each stubbed stage, in arrival order."""

    @property
    def frame(self) -> np.ndarray:
        return self.machine.col.frame

    @property
    def ids(self) -> np.ndarray:
        return self.machine.col.ids


def run_stage(stage: str, program: Program, host_messages: list[list[int]], config: MachineConfig,
              image: MemoryImage | None = None, max_cycles: int = 2_000_000) -> StageRun:
    """Run `program` on `stage` of PE 0 with stubs elsewhere; `host_messages` (raw words, e.g.
    from `encode_message`) are the host stream."""
    if program.proc != stage:
        raise ValueError(f"a {program.proc.upper()} program cannot run on {stage.upper()}")
    programs = {s: assemble_text(_OS_SOURCE_SINK if s == "os" else _SINK, proc=s,
                                 filename=f"<{s} stub>") for s in STAGES}
    programs[stage] = program
    image = image or MemoryImage()
    image.host = [Segment(0, [("w", np.asarray([w for m in host_messages for w in m], dtype=np.uint64))])]
    machine = Machine(config, programs, image)
    result = machine.run(max_cycles=max_cycles)
    received = {}
    for s in STAGES:
        if s == stage:
            continue
        core = machine.pes[0].cores[s]
        n = wrap32(core.regs[SINK_REGISTER])
        words = [int(w) for w in machine.pes[0].memories[s].local.words[:n]]
        received[s] = split_words(words)
    return StageRun(result, machine, received)
