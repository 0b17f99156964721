"""A processing element: OS, IC and SC with their memories, joined by the CMU ring.

Within a cycle a PE steps its three processors (OS, IC, SC) and then its three CMUs; by the FIFO
rule of cmu.py the order makes no difference to any result. The PE also answers the questions
the machine's end-of-run and deadlock rules ask:

- `progressed()` — in the last cycle some processor issued a bundle or stalled for a reason that
  always resolves by itself (operand, unit, write port, memory, branch), or some word moved
  (CMU, DIS into the host FIFO, COL out of the col FIFO);
- `idle()` — every processor is halted (or absent) or waiting on an empty receive FIFO, and no
  word is anywhere in its FIFOs or links.
"""

from __future__ import annotations

import numpy as np

from netsushisen.asm.objects import Program
from netsushisen.isa.errors import NetsushisenError
from netsushisen.isa.config import MachineConfig
from netsushisen.isa.processors import STAGES
from netsushisen.isa.words import word_format

from netsushisen.emulator.cmu import Ring
from netsushisen.emulator.core import Core
from netsushisen.emulator.memories import Memory, MemorySystem, RegionMap, resident_words


def program_words(program: Program | None, precision: str) -> list[int]:
    """A program's `.data` as raw words (loaded at local address 0)."""
    if program is None:
        return []
    wf = word_format(precision)
    return [wf.from_float(v) if k == "f" else wf.from_int(v) for k, v in program.data]


class PE:
    def __init__(self, index: int, config: MachineConfig, programs: dict[str, Program | None],
                 globals_: dict[str, Memory], image=None):
        self.index = index
        self.name = f"pe{index}"
        wf = word_format(config.precision)
        dtype = wf.word_dtype
        self.ring = Ring(config, index)
        self.cores: dict[str, Core] = {}
        self.memories: dict[str, MemorySystem] = {}
        for stage in STAGES:
            local = np.zeros(getattr(config, stage).local_words, dtype=dtype)
            data = program_words(programs.get(stage), config.precision)
            if len(data) > len(local):
                raise NetsushisenError(f"{stage.upper()} program has {len(data)} data words; "
                                       f"{stage}.local_words is {len(local)}")
            local[:len(data)] = data
            resident = None
            gm = None
            if stage != "os":
                mc = config.ic_memory if stage == "ic" else config.sc_memory
                gm = globals_[stage]
                resident = np.zeros(resident_words(mc, gm.size, config.word_bytes), dtype=dtype)
            regions: dict[str, RegionMap] = {}
            if image is not None:
                image.fill(self.index, stage, local, resident)
                regions = image.region_maps(stage)
            mem = MemorySystem(stage, index, config, local, resident, gm, regions)
            recv, send = self.ring.ports(stage)
            self.memories[stage] = mem
            self.cores[stage] = Core(f"{self.name}.{stage}", stage, programs.get(stage), config,
                                     mem, recv, send)
        self.active = [c for c in self.cores.values() if c.present]
        self.ring_moved = False
        self.dis_moved = False
        self.col_moved = False

    def step(self, c: int) -> None:
        for core in self.active:
            core.step(c)
        self.ring_moved = self.ring.step(c)

    def issued(self) -> bool:
        """Some processor of this PE issued a bundle in the last cycle."""
        for core in self.active:
            if core.last_issued:
                return True
        return False

    def progressed(self) -> bool:
        if self.ring_moved or self.dis_moved or self.col_moved:
            return True
        for core in self.cores.values():
            if core.last_issued:
                return True
            if not core.halted and not core.cause.startswith("fifo_"):
                return True
        return False

    def idle(self) -> bool:
        for core in self.active:
            if not core.idle():
                return False
        return self.ring.words_in_flight() == 0

    def all_halted(self) -> bool:
        return all(core.halted for core in self.cores.values())
