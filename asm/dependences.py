"""The dependence graph of a run of operations: what order a schedule must keep, and how far apart.

A pure function of (operations in serial order, processor, machine configuration): the assembler's
scheduler (asm/scheduler.py), its modulo scheduler (asm/pipeline.py) and the static bounds read it.

An edge `src -> dst` with `latency` L and `distance` d says: in any schedule with issue cycles t
(and initiation interval II for a loop), `t[dst] + d·II >= t[src] + L`. `d` is 0 for two operations
of one pass through the code and 1 for a loop-carried edge (dst in the next iteration). L may be 0:
dst may share src's bundle (then it is placed after src in the bundle).

The machine's bundle semantics decide the latencies (docs/timing.md T2-T8; docs/scheduling.md):

- **true** (read after write of register r): L = the writer's result latency (`result_latency`),
  so the reader issues when the value is readable and never stalls on it.
- **anti** (write after read): L = 0. A bundle reads all its operands at issue and writes its
  results later, so the writer may share the reader's bundle (never earlier: an earlier write
  would be seen by the reader, or stall it).
- **output** (write after write): L = the first writer's latency: the scoreboard holds a bundle
  whose destination is still pending (T3), and a bundle may not write one register twice.
- **memory**: local stores against local loads and stores that may touch the same word. A store
  writes at issue after the bundle's loads read (T6): store -> load L = 1, load -> store L = 0,
  store -> store L = 0 (a bundle's stores are applied in bundle order). Two accesses through the
  same base register with no write of it between them (or both absolute, base r0) and different
  offsets never alias; resident and global memory are read-only and never conflict.
- **order** (`.sched inorder` only): every load from resident or global memory after the previous
  one, L = the previous load's issue hold. Those memories are read-only, so the order does not
  change a result, but it is what the cache sees and what the paper counts: IC reads a shape
  record's words in address order (docs/databases.md), and a region holding those loads keeps
  them so.
- **fifo**: every FIFO operation (send, recv, poll, room, wait) after the previous one, L = 1: one
  per bundle, in order, so words move in the serial order and no bundle waits for a word and a
  slot at once (which could deadlock a ring the serial order does not).
- **control**: every operation -> the control transfer or halt that ends the block, L = 0 (it may
  share the last bundle: the operations of a bundle issue whatever the branch decides). In a
  superblock (`.deadout`: blocks joined through the fall-through of branches out of the region)
  a branch is a side exit: the operations after it keep behind it (L = 1) unless `speculable` —
  register computations into registers dead at every exit, which may issue above it.

With `loop=True` the operations are one iteration of a single-block loop whose last operation
is its back edge, and loop-carried edges (d = 1) join iteration j to j+1: registers read before
their first write in the body read the previous iteration's last write (true), the last readers
of a register come before the next iteration's first write (anti), the last write before the
next first write (output), every store against every local access of the next iteration (memory;
no alias reasoning across iterations), and the last FIFO operation before the next first one.
The back edge's control dependence on iteration j+1 is not an edge: a pipelined loop tests it in
the last bundle of its first stage, before any operation of the next iteration (docs/scheduling.md).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property

from netsushisen.asm.objects import Op
from netsushisen.isa.config import MachineConfig
from netsushisen.isa.processors import ZERO_REGISTER, Processor

MAX_ALIAS_OPS = 256
"""Local memory accesses of one block analysed pair by pair for aliasing (the module
docstring's rule). A block with more keeps all its local accesses in serial order instead — a
chain, each after the previous with the latency the pair would need (store -> load 1, else 0),
which orders every pair that may alias at the cost of a linear number of edges (2,000 accesses
checked pairwise took 10 s)."""

FIFO_KINDS = frozenset({"send", "recv", "poll", "room", "wait"})
ORDERED_SPACES = frozenset({"resident", "global"})  # loads `.sched inorder` keeps in order
BLOCK_END_KINDS = frozenset({"branch", "jump", "jumpr", "call", "ret", "halt"})


def result_latency(op: Op, proc: Processor, config: MachineConfig) -> int:
    """Cycles from an operation's issue until its result is readable (T2, T6): the configured
    latency of its mnemonic (`<proc>.latency.<m>`, else the opcode table's); for IC/SC loads the
    memory's access time — t_r for local and resident memory, t_c for global memory (a cache hit:
    a miss costs t_g, unknowable before the run); for OS loads the `ld` latency."""
    oc = op.opcode
    if oc.kind == "load" and proc.name != "os":
        mem = config.ic_memory if proc.name == "ic" else config.sc_memory
        return mem.t_c if oc.space == "global" else mem.t_r
    return getattr(config, proc.name).latency.get(op.mnemonic, oc.latency)


def issue_hold(op: Op, proc: Processor, config: MachineConfig) -> int:
    """Cycles a bundle holding this operation keeps the next bundle from issuing (T6, T7 aside):
    a load's access time (it holds issue until its value is readable), else 1."""
    return result_latency(op, proc, config) if op.opcode.kind == "load" else 1


def unit_busy(op: Op, proc: Processor, config: MachineConfig) -> int:
    """Cycles the operation occupies its unit (T4): its latency if the unit is not pipelined."""
    return 1 if op.opcode.pipelined else result_latency(op, proc, config)


@dataclass(frozen=True)
class Edge:
    src: int
    dst: int
    latency: int
    distance: int
    kind: str  # true, anti, output, memory, fifo, control
    reg: int | None = None
    """The register of a true / anti / output edge."""


@dataclass
class DependenceGraph:
    """Operations (serial order) and the edges between them; see the module docstring."""

    ops: tuple[Op, ...]
    latencies: tuple[int, ...]
    """Result latency of each operation (`result_latency`)."""
    holds: tuple[int, ...]
    """Issue hold of each operation (`issue_hold`)."""
    edges: tuple[Edge, ...]
    loop: bool = False
    _succ: list[list[Edge]] = field(default_factory=list, repr=False)
    _pred: list[list[Edge]] = field(default_factory=list, repr=False)

    def __post_init__(self) -> None:
        self._succ = [[] for _ in self.ops]
        self._pred = [[] for _ in self.ops]
        for e in self.edges:
            self._succ[e.src].append(e)
            self._pred[e.dst].append(e)

    def succs(self, i: int) -> list[Edge]:
        return self._succ[i]

    def preds(self, i: int) -> list[Edge]:
        return self._pred[i]

    @cached_property
    def heights(self) -> tuple[int, ...]:
        """Longest latency-weighted path from each operation to the end of the block over edges
        of distance 0, counting a sink's own latency (its result is wanted after the block):
        the list scheduler's priority."""
        h = [0] * len(self.ops)
        for i in reversed(range(len(self.ops))):
            best = self.latencies[i] if self.ops[i].writes() else 1
            for e in self._succ[i]:
                if e.distance == 0:
                    best = max(best, e.latency + h[e.dst])
            h[i] = best
        return tuple(h)

    def heights_to(self, end: int) -> tuple[int, ...]:
        """Longest latency-weighted path from each operation up to `end` to operation `end`
        over edges of distance 0 (0 at `end` itself): a superblock's priority towards one of its
        side exits, not past it."""
        h = [0] * (end + 1)
        for i in reversed(range(end)):
            h[i] = max((e.latency + h[e.dst] for e in self._succ[i]
                        if e.distance == 0 and e.dst <= end), default=0)
        return tuple(h)

    def critical_path(self) -> int:
        """Cycles from the first issue to the last result of one pass, ignoring resources."""
        return max(self.heights, default=0)


def dependences(ops: list[Op] | tuple[Op, ...], proc: Processor, config: MachineConfig,
                loop: bool = False, inorder: bool = False,
                deadout: frozenset[int] | None = None) -> DependenceGraph:
    """The dependence graph of `ops` (serial order) on `proc` under `config`; `loop=True` adds
    the loop-carried edges of a single-block loop whose body is `ops`, `inorder=True` the order
    of resident and global loads, `deadout` makes `ops` a superblock: branches inside it are side
    exits, and an operation after one may move above it only if it is `speculable` under
    `deadout` (module docstring)."""
    ops = tuple(ops)
    n = len(ops)
    lat = tuple(result_latency(op, proc, config) for op in ops)
    holds = tuple(issue_hold(op, proc, config) for op in ops)
    edges: set[Edge] = set()

    last_write: dict[int, int] = {}
    readers: dict[int, list[int]] = {}  # readers of each register since its last write
    base_version: list[int] = []  # per op: the last writer of its memory base before it (-1)
    mem_ops: list[int] = []
    last_fifo = -1
    last_load = -1
    chained = sum(1 for op in ops if op.opcode.space == "local") > MAX_ALIAS_OPS
    for j, op in enumerate(ops):
        reads, writes = op.reads(), op.writes()
        for r in set(reads):
            if r in last_write:
                i = last_write[r]
                edges.add(Edge(i, j, lat[i], 0, "true", r))
        for r in writes:
            for k in readers.get(r, ()):
                if k != j:
                    edges.add(Edge(k, j, 0, 0, "anti", r))
            if r in last_write:
                i = last_write[r]
                edges.add(Edge(i, j, max(1, lat[i]), 0, "output", r))
        oc = op.opcode
        base = _base(op)
        base_version.append(last_write.get(base, -1) if base is not None else -1)
        if oc.space == "local":
            if chained:
                if mem_ops:
                    edges.add(Edge(mem_ops[-1], j, _memory_latency(ops[mem_ops[-1]], op), 0,
                                   "memory"))
            else:
                for i in mem_ops:
                    if (oc.kind == "store" or ops[i].opcode.kind == "store") and \
                            _may_alias(ops, base_version, i, j):
                        edges.add(Edge(i, j, _memory_latency(ops[i], op), 0, "memory"))
            mem_ops.append(j)
        if inorder and oc.kind == "load" and oc.space in ORDERED_SPACES:
            if last_load >= 0:  # (the previous load holds issue that long: heights count it)
                edges.add(Edge(last_load, j, holds[last_load], 0, "order"))
            last_load = j
        if oc.kind in FIFO_KINDS:
            if last_fifo >= 0:
                edges.add(Edge(last_fifo, j, 1, 0, "fifo"))
            last_fifo = j
        for r in set(reads):
            readers.setdefault(r, []).append(j)
        for r in writes:
            last_write[r] = j
            readers[r] = []
    # control: every operation before a block end -> it, and (a superblock) a side exit -> every
    # later operation that may not move above it. Only the edges no other path implies: an
    # operation before the previous end reaches this one through it (both L = 0), and an
    # operation after the next end is held behind this one by that end (L = 1 each), so the
    # edges are linear in the operations and the schedules are the same.
    ends = [j for j, op in enumerate(ops) if op.opcode.kind in BLOCK_END_KINDS]
    for k, end in enumerate(ends):
        for i in range(ends[k - 1] if k else 0, end):
            edges.add(Edge(i, end, 0, 0, "control"))
        if deadout is not None:
            for j in range(end + 1, ends[k + 1] + 1 if k + 1 < len(ends) else n):
                if not speculable(ops[j], deadout):
                    edges.add(Edge(end, j, 1, 0, "control"))

    if loop and n:
        first_write: dict[int, int] = {}
        for j, op in enumerate(ops):
            for r in op.writes():
                first_write.setdefault(r, j)
        for j, op in enumerate(ops):  # reads before the first write: the previous iteration's
            for r in set(op.reads()):
                if r in first_write and j <= first_write[r]:
                    i = last_write[r]
                    edges.add(Edge(i, j, lat[i], 1, "true", r))
        for r, k_list in readers.items():  # readers after the last write -> next first write
            for k in k_list:
                if r in first_write:
                    edges.add(Edge(k, first_write[r], 0, 1, "anti", r))
        for r, i in last_write.items():
            edges.add(Edge(i, first_write[r], max(1, lat[i]), 1, "output", r))
        if chained and mem_ops:  # the chain closes across the back edge
            edges.add(Edge(mem_ops[-1], mem_ops[0],
                           _memory_latency(ops[mem_ops[-1]], ops[mem_ops[0]]), 1, "memory"))
        for i in mem_ops if not chained else ():
            for j in mem_ops:
                if ops[i].opcode.kind == "store" or ops[j].opcode.kind == "store":
                    if not _distinct_absolute(ops[i], ops[j]):
                        edges.add(Edge(i, j, _memory_latency(ops[i], ops[j]), 1, "memory"))
        fifo = [j for j, op in enumerate(ops) if op.opcode.kind in FIFO_KINDS]
        if fifo:
            edges.add(Edge(fifo[-1], fifo[0], 1, 1, "fifo"))
        loads = [j for j, op in enumerate(ops)
                 if op.opcode.kind == "load" and op.opcode.space in ORDERED_SPACES]
        if inorder and loads:
            edges.add(Edge(loads[-1], loads[0], holds[loads[-1]], 1, "order"))
    ordered = tuple(sorted(edges, key=lambda e: (e.src, e.dst, e.distance, e.kind, e.reg or 0)))
    return DependenceGraph(ops, lat, holds, ordered, loop)


def _base(op: Op) -> int | None:
    for operand, arg in zip(op.opcode.operands, op.args):
        if operand.kind == "mem":
            return arg[0]
    return None


def _offset(op: Op) -> int:
    return next(arg[1] for operand, arg in zip(op.opcode.operands, op.args) if operand.kind == "mem")


def _memory_latency(first: Op, second: Op) -> int:
    """store -> load 1 (the load must see the stored word); otherwise 0 (T6: a bundle's loads
    read before its stores write, and its stores are applied in bundle order)."""
    return 1 if first.opcode.kind == "store" and second.opcode.kind == "load" else 0


def _distinct_absolute(a: Op, b: Op) -> bool:
    return _base(a) == ZERO_REGISTER and _base(b) == ZERO_REGISTER and _offset(a) != _offset(b)


def _may_alias(ops: tuple[Op, ...], version: list[int], i: int, j: int) -> bool:
    """Whether local accesses i and j may touch one word: not if both use the same base register
    holding the same value (no write of it between them; r0 always) at different offsets."""
    a, b = ops[i], ops[j]
    if _base(a) != _base(b) or _offset(a) == _offset(b):
        return True
    return not (_base(a) == ZERO_REGISTER or version[i] == version[j])


def is_fifo(op: Op) -> bool:
    return op.opcode.kind in FIFO_KINDS


def speculable(op: Op, deadout: frozenset[int]) -> bool:
    """Whether `op` may issue above a side exit of a superblock (or in its bundle, which issues
    whatever the branch decides): it only computes into registers dead at every exit of the
    region (`.deadout`) — no memory, FIFO or control operation, no write of a live register."""
    kind = op.opcode.kind
    if kind in BLOCK_END_KINDS or kind in FIFO_KINDS or kind in ("load", "store", "nop"):
        return False
    writes = op.writes()
    return bool(writes) and all(r in deadout for r in writes)


def ends_block(op: Op) -> bool:
    """A control transfer or halt: the last operation of a block (docs/scheduling.md)."""
    return op.opcode.kind in BLOCK_END_KINDS


__all__ = ["DependenceGraph", "Edge", "dependences", "ends_block", "is_fifo", "speculable",
           "issue_hold", "result_latency", "unit_busy"]
