"""Linear assembly: a `.sched` ... `.endsched` region's operations into bundles.

The region is cut into blocks — a label starts one, a control transfer or halt ends one — and
each block is list-scheduled (asm/scheduler.py); a block that a `.pipeline` label heads and whose
last operation branches back to that label is software-pipelined (asm/pipeline.py), or
list-scheduled with the reason it could not be. The result is a `Layout` of region-local
operation indices (renamed where pipelined) that the assembler turns into bundles.
"""

from __future__ import annotations

from dataclasses import dataclass

from netsushisen.asm.dependences import ends_block
from netsushisen.asm.objects import Op
from netsushisen.asm.pipeline import Layout, Placed, PipelineReport, pipeline_loop
from netsushisen.asm.scheduler import list_schedule
from netsushisen.isa.config import MachineConfig
from netsushisen.isa.processors import Processor


@dataclass
class RegionLoop:
    """A `.pipeline` mark: the region-local index of the loop's head and how to name it."""

    head: int
    name: str
    where: str


def blocks(n: int, ops: list[Op], starts: set[int]) -> list[tuple[int, int]]:
    """[start, end) of each block of a region's operations."""
    out = []
    first = 0
    for i in range(n):
        if i in starts and i > first:
            out.append((first, i))
            first = i
        if ends_block(ops[i]):
            out.append((first, i + 1))
            first = i + 1
    if first < n:
        out.append((first, n))
    return out


def schedule_region(ops: list[Op], targets: list[int | None], starts: set[int],
                    loops: list[RegionLoop], temps: list[int], proc: Processor,
                    config: MachineConfig) -> tuple[Layout, dict[int, int], list[PipelineReport]]:
    """The region's layout, where each block start (region-local index) lands, and a report per
    `.pipeline` loop. `targets[i]`: the region-local index operation i branches to, if inside."""
    layout = Layout()
    starts_at: dict[int, int] = {}
    reports = []
    heads = {loop.head: loop for loop in loops}
    for k, (a, b) in enumerate(blocks(len(ops), ops, starts | set(heads))):
        starts_at[a] = len(layout.bundles)
        body = ops[a:b]
        loop = heads.get(a)
        if loop is not None:
            report = PipelineReport(loop.name, loop.where, 0)
            reports.append(report)
            if targets[b - 1] != a:
                report.ops = len(body)
                report.reason = "it is not a single-block loop (its last operation does not branch back to its head)"
            else:
                sub = pipeline_loop(body, proc, config, temps, report)
                if sub is not None:
                    prefix = f"{loop.name}."
                    for bundle in sub.bundles:
                        layout.bundles.append([_shift(p, a, prefix) for p in bundle])
                    for name, at in sub.labels.items():
                        layout.labels[prefix + name] = starts_at[a] + at
                    continue
        for bundle in list_schedule(body, proc, config):
            layout.bundles.append([Placed(a + i) for i in bundle])
    starts_at[len(ops)] = len(layout.bundles)
    return layout, starts_at, reports


def _shift(p: Placed, offset: int, prefix: str) -> Placed:
    return Placed(p.index + offset if p.index >= 0 else -1, p.reads, p.writes, p.mnemonic,
                  prefix + p.target if p.target else "", p.op,
                  p.source + offset if p.source >= 0 else -1)
