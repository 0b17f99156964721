"""Reference-engine speed: simulated bundles per second (prints; never asserts).

Runs a small VLIW loop on IC (FP chains, a load through the cache, a taken branch per
iteration) and a message ping-pong through the ring, and reports simulated cycles and bundles
per wall-clock second. Usage: python benchmarks/bench_emulator.py [iterations]
"""

from __future__ import annotations

import sys
import time

from netsushisen.asm.assembler import assemble_text
from netsushisen.emulator.machine import Machine
from netsushisen.isa.config import MachineConfig
from netsushisen.isa.images import image_from_json

IC_LOOP = """
        li r1, {n}
        lf r2, 1.5
        lf r3, 0.25
        li r10, 0
loop:   {{ addi r1, r1, -1 ; fmul r4, r2, r3 ; fadd r5, r2, r3 }}
        {{ ldg r7, [r10] ; fsub r6, r2, r3 ; fmax r11, r2, r3 }}
        {{ addi r10, r10, 1 ; fadd r8, r4, r5 ; fmul r9, r6, r6 }}
        andi r10, r10, 4095
        {{ fadd r12, r8, r9 ; fmin r13, r11, r2 ; fabs r14, r3 }}
        {{ bnez r1, loop ; fmul r15, r12, r13 }}
        halt
"""

PING_OS = """
        li r1, {n}
        li r2, (DEST_IC << HDR_DEST_SHIFT) | 1
loop:   send ring, r2
        send ring, r1
        recv r3, ring
        recv r4, ring
        addi r1, r1, -1
        bnez r1, loop
        halt
"""
PING_IC = """
        li r2, (1 << HDR_CLS_SHIFT) | (DEST_OS << HDR_DEST_SHIFT) | 1
loop:   recv r3, ring
        recv r4, ring
        send ring, r2
        send ring, r4
        addi r4, r4, -1
        bnez r4, loop
        halt
"""


def measure(name: str, machine: Machine) -> float:
    t0 = time.perf_counter()
    result = machine.run()
    dt = time.perf_counter() - t0
    bundles = sum(c.bundles_issued for c in machine.cores)
    print(f"{name:<12} {result.status:<9} {result.cycles:>8} cycles {bundles:>8} bundles "
          f"{dt:7.2f} s  {bundles / dt:>9.0f} bundles/s  {result.cycles / dt:>9.0f} cycles/s")
    return bundles / dt


def main(argv: list[str]) -> None:
    n = int(argv[0]) if argv else 5000
    image = image_from_json({"icgm": [float(i) for i in range(4096)]})
    measure("ic-loop", Machine(MachineConfig(), {"ic": assemble_text(IC_LOOP.format(n=n), "ic")},
                               image))
    measure("ring-ping", Machine(MachineConfig(), {
        "os": assemble_text(PING_OS.format(n=n // 4), "os"),
        "ic": assemble_text(PING_IC, "ic")}))


if __name__ == "__main__":
    main(sys.argv[1:])
