"""The machine's state as dense arrays, read from the reference engine's objects and written back.

`flatten(machine)` reads every piece of mutable state of a reference `Machine` — at the start
of a run or in the middle of one — into int64 arrays the compiled loop (loop.py) works on;
`write_back(state, machine)` puts it all back. So the compiled engine can start from any state
the reference engine reached (tandem checks, debugger hand-off) and leave behind a machine the
reference engine, the statistics and the debugger read as if it had run the cycles itself.

The index constants below name the columns of those arrays; loop.py imports them.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass, field

import numpy as np

from netsushisen.isa import stalls as S
from netsushisen.isa.opcodes import OPCODES
from netsushisen.isa.processors import STAGES

from netsushisen.emulator.cmu import PREV
from netsushisen.emulator.machine import Machine


def _enum(names: str) -> dict[str, int]:
    return {n: i for i, n in enumerate(names.split())}


# core scalars: cs[processor, C_*]
_C = _enum("PC HALTED HOLD_UNTIL HOLD_MEM_UNTIL HOLD_CAUSE HOLD_PC CYCLES BUNDLES LAST_PC "
           "LAST_ISSUED CAUSE PRESENT NB WPORTS PENALTY PE T_LOCAL T_R T_C T_G SEG_LOCAL "
           "SEG_RES SEG_GLOBAL CACHE_SETS CACHE_OFF BLOCK_BYTES WORD_BYTES LOCAL_READS "
           "LOCAL_WRITES RES_READS CACHE_ACC CACHE_HITS CACHE_MISSES GLOBAL_ACC WAKE WAKE_CAUSE NPEND "
           "FIFOWAIT BSHIFT SSHIFT BUSYMAX SLEEP RUN_N RUN_PC RUN_CAUSE AHEAD AHEAD_ISSUED AHEAD_CAUSE "
           "CACHE_WAYS RECORD")
(C_PC, C_HALTED, C_HOLD_UNTIL, C_HOLD_MEM_UNTIL, C_HOLD_CAUSE, C_HOLD_PC, C_CYCLES, C_BUNDLES,
 C_LAST_PC, C_LAST_ISSUED, C_CAUSE, C_PRESENT, C_NB, C_WPORTS, C_PENALTY, C_PE,
 C_T_LOCAL, C_T_R, C_T_C, C_T_G, C_SEG_LOCAL, C_SEG_RES, C_SEG_GLOBAL, C_CACHE_SETS,
 C_CACHE_OFF, C_BLOCK_BYTES, C_WORD_BYTES, C_LOCAL_READS, C_LOCAL_WRITES, C_RES_READS,
 C_CACHE_ACC, C_CACHE_HITS, C_CACHE_MISSES, C_GLOBAL_ACC, C_WAKE, C_WAKE_CAUSE,
 C_NPEND, C_FIFOWAIT, C_BSHIFT, C_SSHIFT, C_BUSYMAX, C_SLEEP, C_RUN_N, C_RUN_PC,
 C_RUN_CAUSE, C_AHEAD, C_AHEAD_ISSUED, C_AHEAD_CAUSE, C_CACHE_WAYS, C_RECORD) = range(len(_C))
"""C_WAKE, C_WAKE_CAUSE: derived, not written back — a processor stalled on an operand, a
destination or a busy unit stalls for that same cause until the cycle C_WAKE (nothing but its
own issue changes what those checks read), so the loop charges those cycles without checking.
C_NPEND (derived): results in flight. C_FIFOWAIT (derived): the processor waits on a FIFO with
no result in flight, so every earlier issue check (operands, destinations, units, write ports)
still passes and only the FIFO checks need doing again. C_BSHIFT, C_SSHIFT: log2 of the words
per cache block and of the sets where those are powers of two (else -1): shifts for divisions.
C_BUSYMAX (derived): the latest cycle any unit is occupied until (units are free from then on).
C_SLEEP (derived): 0, or the first cycle not yet charged of a processor asleep — one stalled on
its FIFOs with nothing in flight and no word on its way, whose stall can end only when a word
reaches one of its receive FIFOs or leaves one of its send FIFOs (pw W_WAKE says when). Asleep,
it is not stepped; its cycles are charged to its stall at once when it wakes or the loop
returns (loop.py wake).
C_RUN_N, C_RUN_PC, C_RUN_CAUSE (derived): stall cycles not yet added to the counters (stpc),
all at the same PC and cause. A stalled processor usually stalls for the same cause at the same
PC for several cycles running; counting the run and adding it once, when the PC or cause
changes or the loop returns (loop.py stall, flush_stalls), spares a scattered increment per
stalled cycle in a table too big for the cache (~2 MB).
C_AHEAD (derived): 1 while the processor has run ahead of the machine (loop.py run_ahead): its
bundles up to its next FIFO operation touch nothing another part of the machine reads, so it
steps through them at once and then sleeps (C_SLEEP: the cycle it has reached). Meanwhile the
end-of-run checks see it as stalled for a cause of its own (C_LAST_ISSUED 0, C_CAUSE branch);
C_AHEAD_ISSUED and C_AHEAD_CAUSE keep the real values until it wakes.
C_RECORD: 1 when the processor's resident and global loads are recorded (Engine.record_loads),
2 when its local loads are too: each goes into `lrec` as `address << 18 | processor << 2 |
hit << 1 | resident` (a local load: the low bits 3)."""
N_C = len(_C)

# decoded bundles: bun[processor, pc, B_*]; reads up to 8, writes up to 4, (class, count) pairs
B_NOPS, B_NREADS, B_READS = 0, 1, 2
B_NWRITES, B_WRITES = 10, 11
B_NUNITS, B_UNITS = 15, 16
B_UFIT, B_NRECVS, B_RECVS, B_NSENDS, B_SENDS, B_WAITS, B_NWTOTAL = 20, 21, 22, 26, 27, 31, 32
"""B_UFIT: every unit class the bundle needs has that many units (so free units never stall it);
B_NWTOTAL: the register writes of all its operations (bounds what the write-port check counts)."""
B_LOAD0, B_LOAD1 = 33, 34  # slots of the bundle's loads (or -1)
B_NWLAT, B_WLAT = 35, 36  # (latency, register writes) of the other writers, by distinct latency
B_LATE, B_UNPIPED = 44, 45  # has FIFO operations or stores; has an unpipelined operation
B_PRIVATE = 46  # touches only its processor's own state: no FIFO operation, no halt
N_B = 47

# decoded operations: ops[processor, pc, slot, O_*]; O_R.. the three source registers in order
(O_KIND, O_MN, O_UNIT, O_LAT, O_PIPE, O_RD, O_SRC, O_R, O_R1, O_R2, O_BASE, O_SPACE, O_PORT,
 O_TARGET, O_NWRITES) = range(15)
N_O = 15
"""The integer immediate and the memory offset (full 32-bit values) live in opk[..., 0 / 1],
the float immediate in opf."""

KINDS = ("alu", "load", "store", "branch", "jump", "jumpr", "call", "ret", "send", "recv",
         "poll", "room", "wait", "halt", "nop")
(K_ALU, K_LOAD, K_STORE, K_BRANCH, K_JUMP, K_JUMPR, K_CALL, K_RET, K_SEND, K_RECV, K_POLL,
 K_ROOM, K_WAIT, K_HALT, K_NOP) = range(len(KINDS))

SPACES = ("local", "resident", "global")
SP_LOCAL, SP_RESIDENT, SP_GLOBAL = range(3)
PORTS = S.FIFO_PORTS  # ("ring", "host", "col"): a port id is its index

MNEMONICS = tuple(OPCODES)
MN_ID = {m: i for i, m in enumerate(MNEMONICS)}
NM = len(MNEMONICS)

# stall causes: ids of the reference engine's cause strings, numbered from the one stall table
# (isa/stalls.py: each concrete cause in table order, a family's parameters in PARAMETERS
# order) after the core's two states that are no stall, "" and "halted"
CAUSES: tuple[str, ...] = ("", "halted") + S.concrete_causes()
"""The names of isa/stalls.py's causes (and the core's "" and "halted" states) by id."""


def _family_base(family: str, values: tuple[str, ...]) -> int:
    """The id of a family's first parameter; the loop adds the parameter's index (a port id,
    a mnemonic id + 1), so the table must list the family's values in that order."""
    base = CAUSES.index(S.stall(family, values[0]))
    assert CAUSES[base:base + len(values)] == tuple(S.stall(family, v) for v in values), family
    return base


CAUSE_NONE, CAUSE_HALTED, CAUSE_BRANCH, CAUSE_LOCAL, CAUSE_RESIDENT, CAUSE_CACHE_HIT, \
    CAUSE_CACHE_MISS, CAUSE_WRITE_PORT, CAUSE_FIFO_ANY = (
        CAUSES.index(c) for c in ("", "halted", S.BRANCH, S.LOCAL, S.RESIDENT, S.CACHE_HIT,
                                  S.CACHE_MISS, S.WRITE_PORT, S.FIFO_ANY))
CAUSE_FIFO_EMPTY = _family_base(S.FIFO_EMPTY, PORTS)  # + port id
CAUSE_FIFO_FULL = _family_base(S.FIFO_FULL, PORTS)  # + port id
CAUSE_OPERAND = _family_base(S.OPERAND, ("",) + MNEMONICS)  # + producer mnemonic id + 1
CAUSE_WAW = _family_base(S.WAW, ("",) + MNEMONICS)
CAUSE_UNIT = _family_base(S.UNIT_BUSY, ("",) + MNEMONICS)
CAUSE_ID = {c: i for i, c in enumerate(CAUSES)}
MEMORY_CAUSE = {S.LOCAL: CAUSE_LOCAL, S.RESIDENT: CAUSE_RESIDENT, S.CACHE_HIT: CAUSE_CACHE_HIT,
                S.CACHE_MISS: CAUSE_CACHE_MISS}
CAUSE_FLAGS = np.array([2 if c.startswith(S.FIFO_EMPTY) else 1 if c.startswith(S.FIFO_FULL) else 0
                        for c in CAUSES], np.int64)
"""0: not a FIFO wait; 1: a FIFO wait (`fifo_full`); 2: waiting on an empty receive FIFO."""

# FIFOs: fq[fifo, Q_*]
Q_CAP, Q_DELAY, Q_HEAD, Q_CNT, Q_POPC, Q_POPS, Q_PEAK, Q_TOTAL, Q_PE, Q_RING, Q_CSTAGE, Q_CIN, \
    Q_RSTAGE, Q_SSTAGE = range(14)
"""Q_CSTAGE, Q_CIN: the CMU (stage) reading this FIFO as an input and the input's index, or -1.
Q_RSTAGE, Q_SSTAGE: the stage of the PE's processor receiving from / sending into it, or -1."""
# words in flight per PE (derived, kept up to date by every push and pop): pw[pe, W_*]
W_ALL, W_RING, W_LASTVIS, W_MASK = range(4)
W_WAKE = W_MASK + 3
"""W_LASTVIS: the latest cycle at which a word pushed so far becomes visible. W_MASK + s: the
inputs of the PE's CMU s that hold words, one bit per input. W_WAKE + s: the first cycle the
PE's processor s, asleep (C_SLEEP), must check its FIFOs again."""
# CMUs: cm[cmu, M_*]
M_N, M_RECV_OWNER, M_MOVED, M_RECV, M_DEST, M_LINK_IN, M_LINK_OUT, M_NOUT = range(8)
# PEs: pes[pe, P_*]
P_MOVED, P_DIS_MOVED, P_COL_MOVED, P_NO_PROGRESS, P_HOST, P_COL = range(6)
# DIS, COL, globals
D_DYNAMIC, D_NEXT, D_NMSGS, D_WORDS_SENT = range(4)
L_MESSAGES, L_WORDS, L_WIDTH, L_HEIGHT = range(4)
G_CYCLE, G_DEADLOCK_CYCLES, G_POOLED, G_NPES, G_W, G_STOP_P, G_STOP_PC, G_AHEAD = range(8)
"""G_AHEAD: processors may run ahead (C_AHEAD); off where the loop must be able to stop in any
cycle with every processor there: a stop point, or the rerun after a fault or deadlock."""

# run-loop status codes and fault kinds (finfo[0])
S_RUNNING, S_HALTED, S_FINISHED, S_DEADLOCK_PE, S_DEADLOCK_COL, S_FAULT, S_STOPPED = range(7)
S_DEADLOCK_MSG = 7
"""A processor stopped in the middle of sending a message on the ring (machine.unsent_messages)."""
F_PC, F_MEMORY, F_RING_COL, F_COL_HEADER, F_COL_PIXEL = range(1, 6)

_ROUTE_NONE = -2

RECORD_CAPACITY = 1 << 22
"""Loads `lrec` holds (32 MB): the engine ends a chunk of cycles before it can fill up (a
processor issues at most two loads a cycle) and takes the codes out between chunks."""


def record_codes(lrec: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(processor, emulator/loads.py code) of each load recorded in `lrec`, in order."""
    e = lrec[1:1 + int(lrec[0])]
    return (e >> 2) & 0xFFFF, ((e >> 18) << 2) | (e & 3)


@dataclass
class State:
    """Every array the loop takes, in its argument order, plus what write-back needs."""

    arrays: dict
    fifos: list
    region_names: list[str]
    mask: int
    dims: dict = field(default_factory=dict)
    """The sizes ARRAYS' shapes name (DIMS), as flatten found them."""

    def args(self) -> tuple:
        a = self.arrays
        return tuple(a[k] for k in ARG_ORDER)


@dataclass(frozen=True)
class Array:
    """One array the loop takes: its element type, its shape and initial fill, and whether the
    loop only reads it (the decoded program, the layouts, the messages to send). A shape is a
    tuple of sizes: an int (a column count such as N_C), or the name of a size flatten finds
    (DIMS). flatten allocates each array from its entry (`_new`) and `check_shapes` holds every
    array it returns to its entry, so the table is the layout, not a comment on it."""

    dtype: str
    """A numpy dtype; "uint32|int64": the memory words, uint32 for fp32 and int64 for fp64."""
    shape: tuple
    read_only: bool = False
    fill: int = 0
    note: str = ""


DIMS = {
    "P": "processors", "NB": "bundles of the longest program (at least 1)",
    "W": "write-back slots, a power of two past any latency", "SLOTS": "operations a bundle",
    "CAUSES": "stall-cause ids (len(CAUSES))", "F": "FIFOs", "CAP": "a FIFO's ring buffer",
    "PES": "PEs", "K": "CMUs (3 a PE)", "IN": "inputs of the widest CMU",
    "WORDS": "words of every memory segment", "SEGMENTS": "memory segments",
    "LINES": "lines of every cache (sets × ways, a set's ways MRU first)",
    "REGIONS": "database regions", "MAPPED": "mapped words", "NAMES": "region names",
    "PRIMS": "primitives", "MSGS1": "host messages + 1", "HOSTWORDS": "host words",
    "H": "frame height", "WIDTH": "frame width",
    "LREC": "1 + recorded loads' capacity: lrec[0] their count, then C_RECORD's codes (a run "
            "that records none: 1)",
}
"""The sizes an ARRAYS shape may name; flatten finds them (State.dims)."""

ARRAYS: dict[str, Array] = {
    "g": Array("int64", (8,), note="G_*"), "until": Array("int", (), note="the chunk's last cycle + 1"),
    "cs": Array("int64", ("P", N_C), note="C_*"), "regs": Array("int64", ("P", 64)),
    "ready": Array("int64", ("P", 64)), "prod": Array("int64", ("P", 64), fill=-1),
    "wbn": Array("int64", ("P", "W")), "wbr": Array("int64", ("P", "W", 4)),
    "wbw": Array("int64", ("P", "W", 4)), "busy": Array("int64", ("P", 2, 4)),
    "occ": Array("int64", ("P", 2, 4), fill=-1), "unitn": Array("int64", ("P", 2), True),
    "stpc": Array("int64", ("P", "NB", "CAUSES")), "bpc": Array("int64", ("P", "NB")),
    "ops": Array("int32", ("P", "NB", "SLOTS", N_O), True, note="O_*"),
    "opk": Array("int64", ("P", "NB", "SLOTS", 2), True),
    "opf": Array("float64", ("P", "NB", "SLOTS"), True),
    "bun": Array("int32", ("P", "NB", N_B), True, note="B_*"),
    "recvq": Array("int64", ("P", 3), True, fill=-1),
    "sendq": Array("int64", ("P", 3), True, fill=-1), "fq": Array("int64", ("F", 14), note="Q_*"),
    "fbt": Array("int64", ("F", "CAP")), "fbw": Array("int64", ("F", "CAP")),
    "mem": Array("uint32|int64", ("WORDS",)),
    "seg": Array("int64", ("SEGMENTS", 2), True),
    "ctags": Array("int64", ("LINES",)),
    "rg": Array("int32", ("REGIONS", 2), True), "rmap": Array("int64", ("P", 3, 2), True),
    "rdense": Array("int32", ("MAPPED",), True),
    "rcnt": Array("int64", ("P", 3, "NAMES", 3)), "pcnt": Array("int64", ("P", 3, "PRIMS")),
    "cm": Array("int64", ("K", 8), note="M_*"), "cin": Array("int64", ("K", "IN"), True),
    "cout": Array("int64", ("K", "IN"), True),
    "route": Array("int64", ("K", "IN"), fill=_ROUTE_NONE),
    "rem": Array("int64", ("K", "IN")), "lown": Array("int64", ("K", "IN"), fill=-1),
    "linkw": Array("int64", ("K",)), "pes": Array("int64", ("PES", 6), note="P_*"),
    "dis": Array("int64", (4,), note="D_*"), "dcur": Array("int64", ("PES",)),
    "doff": Array("int64", ("PES",)), "dup": Array("int64", ("PES",)),
    "dasg": Array("int64", ("PES",)), "moff": Array("int64", ("MSGS1",), True),
    "mwords": Array("int64", ("HOSTWORDS",), True), "col": Array("int64", (4,), note="L_*"),
    "cpart": Array("int64", ("PES", 8)), "cplen": Array("int64", ("PES",)),
    "frame": Array("float64", ("H", "WIDTH", 3)), "ids": Array("int32", ("H", "WIDTH")),
    "cflags": Array("int64", ("CAUSES",), True),
    "pw": Array("int64", ("PES", W_WAKE + 3), note="W_*"),
    "lrec": Array("int64", ("LREC",), note="recorded loads"),
    "finfo": Array("int64", (8,), note="fault kind and where"),
}
"""Every array the loop takes, in its argument order (loop.py unpacks them in this order)."""


def shape_of(name: str, dims: dict[str, int]) -> tuple[int, ...]:
    """The shape ARRAYS declares for array `name`, its named sizes read from `dims`."""
    return tuple(dims[d] if isinstance(d, str) else d for d in ARRAYS[name].shape)


def check_shapes(st: State) -> list[str]:
    """Every array of `st` whose shape or dtype is not its ARRAYS entry's (empty: all are)."""
    out = []
    for name, spec in ARRAYS.items():
        v = st.arrays[name]
        if not spec.shape:
            if not isinstance(v, int):
                out.append(f"{name}: {type(v).__name__}, not a scalar")
            continue
        if v.shape != shape_of(name, st.dims) or str(v.dtype) not in spec.dtype.split("|"):
            out.append(f"{name}: {v.dtype}{v.shape}, declared {spec.dtype}{shape_of(name, st.dims)}")
    return out


ARG_ORDER = tuple(ARRAYS)
READ_ONLY = frozenset(k for k, v in ARRAYS.items() if v.read_only)
"""The arrays the loop only reads (a chunk rerun restores only the others)."""


# -- The layout table: each component's scalar state, declared once ------------------------------
# flatten reads these fields from the reference objects, write_back writes them back, and the
# tandem engine's comparison (tandem.canonical) names and compares them — one declaration each.


@dataclass(frozen=True)
class Field:
    """One column of a component's array ↔ one attribute of its reference object."""

    column: int
    attr: str
    """Attribute of the component's object (also the field's name in a tandem mismatch)."""
    kind: str = "int"
    """How a value converts: "int", "bool", or "cause" (a stall-cause string ↔ its CAUSES id)."""
    compare: bool = True
    """Compared by the tandem engine as it stands (False: canonical compares it otherwise, or
    it is bookkeeping whose stale values the engines need not agree on)."""


@dataclass(frozen=True)
class Component:
    """A kind of machine part: its array, its fields, and its objects (one a row, in row order,
    each with the name tandem reports it by; None where a row has no such part)."""

    array: str
    fields: tuple[Field, ...]
    objects: object  # Callable[[Machine], list[tuple[str, object | None]]]

    def rows(self, machine: Machine):
        return self.objects(machine)

    def _cells(self, machine: Machine, arrays: dict):
        """(array row, object, field) of every declared cell, rows in order."""
        arr = arrays[self.array]
        for i, (_name, obj) in enumerate(self.rows(machine)):
            if obj is not None:
                row = arr if arr.ndim == 1 else arr[i]
                for f in self.fields:
                    yield row, obj, f

    def read(self, machine: Machine, arrays: dict) -> None:
        for row, obj, f in self._cells(machine, arrays):
            v = getattr(obj, f.attr)
            row[f.column] = CAUSE_ID[v] if f.kind == "cause" else int(v)

    def write(self, arrays: dict, machine: Machine) -> None:
        for row, obj, f in self._cells(machine, arrays):
            v = row[f.column]
            setattr(obj, f.attr, CAUSES[v] if f.kind == "cause" else
                    bool(v) if f.kind == "bool" else int(v))

    def values(self, machine: Machine):
        """(name.attr, value) of every compared field, for the tandem comparison."""
        for name, obj in self.rows(machine):
            if obj is not None:
                for f in self.fields:
                    if f.compare:
                        yield f"{name}.{f.attr}", getattr(obj, f.attr)


def _cores(machine):
    return [(c.name, c) for c in machine.cores]


def _part(attr: str, label: str):
    """A memory part of each processor (local, resident, cache, or the memory system)."""
    def rows(machine):
        out = []
        for c in machine.cores:
            obj = c.memory if attr == "memory" else getattr(c.memory, attr)
            out.append((f"{c.name}.{label}", obj))
        return out
    return rows


def _fifos(machine):
    return [(f.name, f) for pe in machine.pes for f in pe.ring.fifos()]


def _cmus(machine):
    return [(f"{pe.name}.cmu.{cmu.stage}", cmu) for pe in machine.pes for cmu in pe.ring.cmus]


LAYOUT: tuple[Component, ...] = (
    Component("cs", (Field(C_PC, "pc"), Field(C_HALTED, "halted", "bool"),
                     Field(C_HOLD_UNTIL, "hold_until"), Field(C_HOLD_MEM_UNTIL, "hold_mem_until"),
                     Field(C_HOLD_CAUSE, "hold_cause", "cause"), Field(C_HOLD_PC, "hold_pc"),
                     Field(C_CYCLES, "cycles"), Field(C_BUNDLES, "bundles_issued"),
                     Field(C_LAST_PC, "last_pc"), Field(C_LAST_ISSUED, "last_issued", "bool"),
                     Field(C_CAUSE, "cause", "cause")), _cores),
    Component("cs", (Field(C_LOCAL_READS, "reads"), Field(C_LOCAL_WRITES, "writes")),
              _part("local", "local")),
    Component("cs", (Field(C_RES_READS, "reads"),), _part("resident", "resident")),
    Component("cs", (Field(C_GLOBAL_ACC, "global_accesses"),), _part("memory", "memory")),
    Component("cs", (Field(C_CACHE_ACC, "accesses"), Field(C_CACHE_HITS, "hits"),
                     Field(C_CACHE_MISSES, "misses")), _part("cache", "cache")),
    Component("fq", (Field(Q_POPC, "pop_cycle", compare=False),
                     Field(Q_POPS, "pops", compare=False),
                     Field(Q_PEAK, "peak"), Field(Q_TOTAL, "total")), _fifos),
    Component("cm", (Field(M_RECV_OWNER, "recv_owner"), Field(M_MOVED, "moved")), _cmus),
    Component("pes", (Field(P_MOVED, "ring_moved", "bool", False),
                      Field(P_DIS_MOVED, "dis_moved", "bool", False),
                      Field(P_COL_MOVED, "col_moved", "bool", False)),
              lambda m: [(pe.name, pe) for pe in m.pes]),
    Component("dis", (Field(D_NEXT, "next_msg"), Field(D_WORDS_SENT, "words_sent")),
              lambda m: [("dis", m.dis)]),
    Component("col", (Field(L_MESSAGES, "messages"), Field(L_WORDS, "words")),
              lambda m: [("col", m.col)]),
)
"""The scalar state of every component (the arrays' other contents — registers, results in
flight, queues, memories, counters by region and PC — are structures flatten and write_back
convert explicitly, and canonical compares whole)."""


def _new(name: str, dims: dict[str, int]) -> np.ndarray:
    """Array `name` as ARRAYS declares it: its dtype, its shape (sizes from `dims`), its fill."""
    spec = ARRAYS[name]
    return np.full(shape_of(name, dims), spec.fill, spec.dtype)


def _words(a: np.ndarray) -> np.ndarray:
    """Raw words: uint32 kept (fp32 words; half the bytes of the scene's databases in the
    cache, and read into an int64 register they widen exactly), uint64 reinterpreted as int64."""
    return a.view(np.int64).copy() if a.dtype == np.uint64 else a.astype(np.uint32)


def _as_signed(w: int) -> int:
    return w - (1 << 64) if w >= 1 << 63 else w


def flatten(machine: Machine) -> State:
    cfg = machine.config
    cores = machine.cores
    P = len(cores)
    npes = len(machine.pes)
    mask = (1 << (8 * cfg.word_bytes)) - 1
    NB = max([len(c.bundles) for c in cores] + [1])
    MAXOPS = max([len(b.ops) for c in cores for b in c.bundles] + [1])

    # the write-back ring: longer than any latency or access time (and any result in flight)
    longest = 2
    for core in cores:
        mem = core.memory
        longest = max(longest, mem.t_local, mem.t_r, mem.t_c, mem.t_g)
        for b in core.bundles:
            for d in b.ops:
                longest = max(longest, d.lat)
        for t in core.pending:
            longest = max(longest, t - machine.cycle + 1)
    W = 1
    while W < longest + 2:
        W *= 2

    a: dict = {}
    dims = {"P": P, "NB": NB, "SLOTS": MAXOPS, "W": W, "CAUSES": len(CAUSES), "PES": npes,
            "K": 3 * npes}
    # ops: small fields (half the cache footprint); opk: the integer immediate and memory
    # offset; opf: the float immediate
    cs, regs, ready, prod, wbn, wbr, wbw, busy, occ, unitn, stpc, bpc, ops, opk, opf, bun, \
        recvq, sendq = (_new(n, dims) for n in (
            "cs", "regs", "ready", "prod", "wbn", "wbr", "wbw", "busy", "occ", "unitn", "stpc",
            "bpc", "ops", "opk", "opf", "bun", "recvq", "sendq"))

    # FIFOs, in each PE's fixed order
    fifos = [f for pe in machine.pes for f in pe.ring.fifos()]
    fid = {id(f): i for i, f in enumerate(fifos)}
    # each FIFO a ring buffer of a power-of-two size (loop.py wraps its indices with a mask)
    cap = 1 << (max(f.capacity for f in fifos) - 1).bit_length()
    dims.update(F=len(fifos), CAP=cap)
    fq, fbt, fbw, pw = (_new(n, dims) for n in ("fq", "fbt", "fbw", "pw"))
    cmu_input = {id(f): (s, k) for pe in machine.pes for s, cmu in enumerate(pe.ring.cmus)
                 for k, f in enumerate(cmu.inputs)}
    per_pe = len(fifos) // npes
    for i, f in enumerate(fifos):
        pe = machine.pes[i // per_pe]
        ring = f is not pe.ring.host and f is not pe.ring.col
        stage, k = cmu_input.get(id(f), (-1, -1))
        fq[i] = (f.capacity, f.delay, 0, len(f.q), 0, 0, 0, 0,  # Q_POPC..Q_TOTAL: LAYOUT
                 i // per_pe, ring, stage, k, -1, -1)
        if stage >= 0 and len(f.q):
            pw[i // per_pe, W_MASK + stage] |= 1 << k
        pw[i // per_pe, W_ALL] += len(f.q)
        pw[i // per_pe, W_RING] += len(f.q) if ring else 0
        for t, _ in f.q:
            pw[i // per_pe, W_LASTVIS] = max(pw[i // per_pe, W_LASTVIS], t)
        for k, (t, w) in enumerate(f.q):
            fbt[i, k] = t
            fbw[i, k] = _as_signed(int(w) & mask)

    # memories: one flat array of segments (local and resident per processor, ICGM, SCGM)
    segs: list[np.ndarray] = []

    def add_seg(words: np.ndarray) -> int:
        segs.append(_words(words))
        return len(segs) - 1

    gseg = {stage: add_seg(g.words) for stage, g in machine.globals.items()}
    region_names: list[str] = []
    rg_parts: list[tuple[int, int]] = []  # per region: (name id, primitive or -1)
    rmap = _new("rmap", dims)
    rmap[:, :, 1] = -1
    max_prim = 0
    tags: list[np.ndarray] = []
    tag_off = 0

    def name_id(name: str) -> int:
        if name not in region_names:
            region_names.append(name)
        return region_names.index(name)

    maps_of = []
    for p, core in enumerate(cores):
        mem = core.memory
        maps_of.append((mem.local.regions, mem.resident.regions if mem.resident else None,
                        mem.global_regions))
        for counts in _counters(mem):
            for name in counts.regions:
                name_id(name)
            for prim in counts.primitives:
                max_prim = max(max_prim, prim + 1)
    dense_of: dict[tuple[int, int], tuple[int, np.ndarray]] = {}
    dense_parts: list[np.ndarray] = []
    dense_len = 0
    for p, maps in enumerate(maps_of):
        mem = cores[p].memory
        sizes = (mem.local.size, mem.resident.size if mem.resident is not None else 0,
                 mem.global_memory.size if mem.global_memory is not None else 0)
        for sp, rmap_obj in enumerate(maps):
            if rmap_obj is None or not sizes[sp]:
                continue
            key = (id(rmap_obj), sizes[sp])
            if key not in dense_of:  # a dense per-address map: region index, or -1
                d = np.full(sizes[sp], -1, np.int32)
                for r in rmap_obj.regions:
                    prim = -1 if r.primitive is None else r.primitive
                    max_prim = max(max_prim, prim + 1)
                    d[max(r.start, 0):max(min(r.end, sizes[sp]), 0)] = len(rg_parts)
                    rg_parts.append((name_id(r.name), prim))
                dense_of[key] = (dense_len, d)
                dense_parts.append(d)
                dense_len += len(d)
            rmap[p, sp] = (dense_of[key][0], sizes[sp])
    # side by side (one cache line per counted access)
    rg = np.array(rg_parts, np.int32) if rg_parts else np.zeros((1, 2), np.int32)
    rdense = np.concatenate(dense_parts) if dense_parts else np.zeros(1, np.int32)
    dims.update(NAMES=max(len(region_names), 1), PRIMS=max(max_prim, 1), REGIONS=len(rg),
                MAPPED=len(rdense))
    rcnt, pcnt = _new("rcnt", dims), _new("pcnt", dims)

    for p, core in enumerate(cores):
        mem = core.memory
        proc = core.proc
        units = list(proc.units)
        for u, name in enumerate(units):
            unitn[p, u] = proc.units[name]
            for i, t in enumerate(core.busy[name]):
                busy[p, u, i] = t
                occ[p, u, i] = MN_ID.get(core.occupant[name][i], -1)
        cs[p, C_BUSYMAX] = busy[p].max()

        cs[p, C_PRESENT] = core.present
        cs[p, C_RECORD] = 0 if mem.record is None else 2 if mem.record_local else 1
        cs[p, C_NB] = len(core.bundles)
        cs[p, C_WPORTS] = core.write_ports
        cs[p, C_PENALTY] = core.penalty
        cs[p, C_PE] = p // 3
        cs[p, C_T_LOCAL], cs[p, C_T_R], cs[p, C_T_C], cs[p, C_T_G] = \
            mem.t_local, mem.t_r, mem.t_c, mem.t_g
        cs[p, C_SEG_LOCAL] = add_seg(mem.local.words)
        cs[p, C_SEG_RES] = add_seg(mem.resident.words) if mem.resident is not None else -1
        cs[p, C_SEG_GLOBAL] = gseg[core.proc.name] if mem.global_memory is not None \
            and core.proc.name in gseg else -1
        if mem.cache is not None:
            c = mem.cache
            cs[p, C_CACHE_SETS] = c.sets
            cs[p, C_CACHE_WAYS] = c.ways
            cs[p, C_CACHE_OFF] = tag_off
            cs[p, C_BLOCK_BYTES] = c.block_bytes
            cs[p, C_WORD_BYTES] = c.word_bytes
            tags.append(c.tags.astype(np.int64))
            tag_off += len(c.tags)
            per_block = c.block_bytes // c.word_bytes
            cs[p, C_BSHIFT] = per_block.bit_length() - 1 if c.block_bytes % c.word_bytes == 0 \
                and per_block & (per_block - 1) == 0 else -1
            cs[p, C_SSHIFT] = c.sets.bit_length() - 1 if c.sets and c.sets & (c.sets - 1) == 0 \
                else -1
        else:
            cs[p, C_BLOCK_BYTES] = 1
        for sp, counts in enumerate(_counters(mem)):
            for name, (acc, hits, misses) in counts.regions.items():
                rcnt[p, sp, region_names.index(name)] = (acc, hits, misses)
            for prim, n in counts.primitives.items():
                pcnt[p, sp, prim] = n
        for r in range(64):
            regs[p, r] = _as_signed(int(core.regs[r]) & mask)
            ready[p, r] = core.ready_at[r]
            prod[p, r] = MN_ID.get(core.producer[r], -1)
        for t, lst in core.pending.items():
            s = t & (W - 1)
            for r, w in lst:
                k = wbn[p, s]
                wbr[p, s, k], wbw[p, s, k] = r, _as_signed(int(w) & mask)
                wbn[p, s] = k + 1
                cs[p, C_NPEND] += 1
        for pc, causes in core.stalls_by_pc.items():
            for cause, n in causes.items():
                stpc[p, pc, CAUSE_ID[cause]] = n
        for pc, n in core.bundles_by_pc.items():
            bpc[p, pc] = n
        for port, f in core.recv_ports.items():
            recvq[p, PORTS.index(port)] = fid[id(f)]
            fq[fid[id(f)], Q_RSTAGE] = p % 3
        for port, f in core.send_ports.items():
            sendq[p, PORTS.index(port)] = fid[id(f)]
            fq[fid[id(f)], Q_SSTAGE] = p % 3
        _decode(core, units, ops[p], opk[p], opf[p], bun[p])

    # CMUs and links
    dims["IN"] = max(len(cmu.inputs) for pe in machine.pes for cmu in pe.ring.cmus)
    cm, cin, cout, route, rem, lown, linkw, pes = (_new(n, dims) for n in (
        "cm", "cin", "cout", "route", "rem", "lown", "linkw", "pes"))
    for i, pe in enumerate(machine.pes):
        for s, stage in enumerate(STAGES):
            m = 3 * i + s
            cmu = pe.ring.cmus[s]
            linkw[m] = pe.ring.link_words[stage][0]
            cm[m] = (len(cmu.inputs), 0, 0, fid[id(cmu.recv)], cmu.dest_id,  # 0, 0: LAYOUT
                     3 * i + STAGES.index(PREV[stage]), m, len(cmu.out_link))
            for k, f in enumerate(cmu.inputs):
                cin[m, k] = fid[id(f)]
                route[m, k] = _ROUTE_NONE if cmu.route[k] is None else cmu.route[k]
                rem[m, k] = cmu.remaining[k]
            for k, f in enumerate(cmu.out_link):
                cout[m, k] = fid[id(f)]
                lown[m, k] = cmu.link_owner[k]
        pes[i] = (0, 0, 0, machine.no_progress[i],  # 0, 0, 0: LAYOUT
                  fid[id(pe.ring.host)], fid[id(pe.ring.col)])

    d = machine.dis
    dims["MSGS1"] = len(d.messages) + 1
    moff = _new("moff", dims)
    for k, msg in enumerate(d.messages):
        moff[k + 1] = moff[k] + len(msg)
    mwords = np.array([_as_signed(int(w) & mask) for msg in d.messages for w in msg] or [0],
                      np.int64)
    col = machine.col
    cpart, cplen = _new("cpart", dims), _new("cplen", dims)
    for i, part in enumerate(col.partial):
        cplen[i] = len(part)
        for k, w in enumerate(part):
            cpart[i, k] = _as_signed(int(w) & mask)

    dims["SEGMENTS"] = len(segs)
    seg = _new("seg", dims)
    off = 0
    for i, s in enumerate(segs):
        seg[i] = (off, len(s))
        off += len(s)
    a.update(
        g=np.array([machine.cycle, cfg.ring.deadlock_cycles, cfg.ring.buffer_pool, npes, W, -1, 0,
                    1],
                   np.int64),
        until=0, cs=cs, regs=regs, ready=ready, prod=prod, wbn=wbn, wbr=wbr, wbw=wbw, busy=busy,
        occ=occ, unitn=unitn, stpc=stpc, bpc=bpc, ops=ops, opk=opk, opf=opf, bun=bun,
        recvq=recvq, sendq=sendq, fq=fq, fbt=fbt, fbw=fbw,
        mem=np.concatenate(segs) if segs else np.zeros(1, np.int64), seg=seg,
        ctags=np.concatenate(tags) if tags else np.zeros(1, np.int64), rg=rg, rmap=rmap,
        rdense=rdense,
        rcnt=rcnt, pcnt=pcnt, cm=cm, cin=cin, cout=cout, route=route, rem=rem, lown=lown,
        linkw=linkw, pes=pes,
        dis=np.array([d.dynamic, 0, len(d.messages), 0], np.int64),  # 0: LAYOUT
        dcur=np.array(d.current, np.int64), doff=np.array(d.offset, np.int64),
        dup=np.array(d.upcoming, np.int64), dasg=np.array(d.assigned, np.int64),
        moff=moff, mwords=mwords,
        col=np.array([0, 0, col.width, col.height], np.int64),  # 0: LAYOUT
        cpart=cpart, cplen=cplen, frame=col.frame, ids=col.ids, cflags=CAUSE_FLAGS, pw=pw,
        lrec=np.zeros(1 + (RECORD_CAPACITY if cs[:, C_RECORD].any() else 0), np.int64),
        finfo=np.zeros(8, np.int64))
    for component in LAYOUT:
        component.read(machine, a)
    dims.update(WORDS=len(a["mem"]), LINES=len(a["ctags"]), HOSTWORDS=len(mwords),
                H=col.frame.shape[0], WIDTH=col.frame.shape[1], LREC=len(a["lrec"]))
    return State(a, fifos, region_names, mask, dims)


def _counters(mem) -> tuple:
    """The region counters of a memory system by space (local, resident, global)."""
    return (mem.local.region_counts,
            mem.resident.region_counts if mem.resident is not None else _EMPTY,
            mem.global_counts)


class _Empty:
    regions: dict = {}
    primitives: dict = {}


_EMPTY = _Empty()


def _decode(core, units: list[str], ops: np.ndarray, opk: np.ndarray, opf: np.ndarray,
            bun: np.ndarray) -> None:
    """The reference engine's decoded bundles (core.DBundle / DOp) as rows of integers."""
    for pc, b in enumerate(core.bundles):
        row = bun[pc]
        row[B_NOPS] = len(b.ops)
        row[B_NREADS] = len(b.reads)
        row[B_READS:B_READS + len(b.reads)] = b.reads
        row[B_NWRITES] = len(b.writes)
        row[B_WRITES:B_WRITES + len(b.writes)] = b.writes
        row[B_NUNITS] = len(b.units)
        for k, (u, n) in enumerate(b.units):
            row[B_UNITS + 2 * k], row[B_UNITS + 2 * k + 1] = units.index(u), n
        row[B_UFIT] = all(n <= core.proc.units[u] for u, n in b.units)
        row[B_NRECVS] = len(b.recvs)
        for k, (port, n) in enumerate(b.recvs):
            row[B_RECVS + 2 * k], row[B_RECVS + 2 * k + 1] = PORTS.index(port), n
        row[B_NSENDS] = len(b.sends)
        for k, (port, n) in enumerate(b.sends):
            row[B_SENDS + 2 * k], row[B_SENDS + 2 * k + 1] = PORTS.index(port), n
        row[B_WAITS] = b.waits
        row[B_NWTOTAL] = sum(d.nwrites for d in b.writers)
        row[B_LATE] = any(d.kind in ("recv", "send", "store") for d in b.ops)
        row[B_UNPIPED] = any(not d.pipelined for d in b.ops)
        row[B_PRIVATE] = not any(d.kind in ("send", "recv", "poll", "room", "wait", "halt")
                                 for d in b.ops)
        loads = [j for j, d in enumerate(b.ops) if d.kind == "load"]
        row[B_LOAD0] = loads[0] if loads else -1
        row[B_LOAD1] = loads[1] if len(loads) > 1 else -1
        by_lat: dict[int, int] = {}
        for d in b.writers:
            if d.kind != "load":
                by_lat[d.lat] = by_lat.get(d.lat, 0) + d.nwrites
        row[B_NWLAT] = len(by_lat)
        for k, (lat, n) in enumerate(by_lat.items()):
            row[B_WLAT + 2 * k], row[B_WLAT + 2 * k + 1] = lat, n
        for j, d in enumerate(b.ops):
            o = ops[pc, j]
            o[O_KIND] = KINDS.index(d.kind)
            o[O_MN] = MN_ID[d.m]
            o[O_UNIT] = units.index(d.unit) if d.unit else -1
            o[O_LAT] = d.lat
            o[O_PIPE] = d.pipelined
            o[O_RD] = -1 if d.rd is None else d.rd
            o[O_SRC] = 0 if d.src is None else d.src
            o[O_BASE] = 0 if d.base is None else d.base
            opk[pc, j, 1] = 0 if d.offset is None else d.offset
            o[O_SPACE] = SPACES.index(d.space) if d.space else 0
            o[O_PORT] = PORTS.index(d.port) if d.port else 0
            o[O_TARGET] = 0 if d.target is None else d.target
            o[O_NWRITES] = d.nwrites
            nr = 0
            for k, v, _t in d.args:
                if k == "r":
                    o[O_R + nr] = v
                    nr += 1
                elif any(x.kind == "fimm" for x in OPCODES[d.m].operands):
                    opf[pc, j] = float(v)
                else:
                    opk[pc, j, 0] = int(v)


def write_back(st: State, machine: Machine) -> None:
    """Put the arrays' state back into the reference engine's objects."""
    a = st.arrays
    mask = st.mask
    W = int(a["g"][G_W])
    cycle = int(a["g"][G_CYCLE])
    machine.cycle = cycle
    for component in LAYOUT:
        component.write(a, machine)
    seg = a["seg"]
    mem_all = a["mem"]
    names = st.region_names
    for p, core in enumerate(machine.cores):
        cs = a["cs"][p]
        mem = core.memory
        units = list(core.proc.units)
        core.regs = [int(w) & mask for w in a["regs"][p]]
        core.ready_at = [int(t) for t in a["ready"][p]]
        core.producer = [MNEMONICS[i] if i >= 0 else "" for i in a["prod"][p]]
        pending: dict[int, list[tuple[int, int]]] = {}
        for t in range(cycle, cycle + W):
            s = t & (W - 1)
            n = int(a["wbn"][p, s])
            if n:
                pending[t] = [(int(a["wbr"][p, s, k]), int(a["wbw"][p, s, k]) & mask)
                              for k in range(n)]
        core.pending = pending
        for u, name in enumerate(units):
            k = core.proc.units[name]
            core.busy[name] = [int(t) for t in a["busy"][p, u, :k]]
            core.occupant[name] = [MNEMONICS[i] if i >= 0 else "" for i in a["occ"][p, u, :k]]
        # operations by unit and mnemonic follow from the issue counts per PC
        by_unit: dict[str, int] = {}
        by_mn: dict[str, int] = {}
        n_ops = 0
        for pc in np.nonzero(a["bpc"][p])[0]:
            n = int(a["bpc"][p, pc])
            b = core.bundles[pc]
            n_ops += n * b.n_ops
            for d in b.ops:
                if d.unit:
                    by_unit[d.unit] = by_unit.get(d.unit, 0) + n
                    by_mn[d.m] = by_mn.get(d.m, 0) + n
        core.ops_by_unit, core.ops_by_mnemonic, core.ops = by_unit, by_mn, n_ops
        stpc = a["stpc"][p]
        by_pc: dict[int, dict[str, int]] = {}
        totals: dict[str, int] = {}
        for pc, cause in zip(*np.nonzero(stpc)):
            n = int(stpc[pc, cause])
            by_pc.setdefault(int(pc), {})[CAUSES[cause]] = n
            totals[CAUSES[cause]] = totals.get(CAUSES[cause], 0) + n
        core.stalls_by_pc = by_pc
        core.stalls = totals
        core.bundles_by_pc = {int(pc): int(a["bpc"][p, pc]) for pc in np.nonzero(a["bpc"][p])[0]}
        # memories: local words (the only ones a run writes) and every counter
        sl = seg[cs[C_SEG_LOCAL]]
        words = mem_all[sl[0]:sl[0] + sl[1]]
        dt = mem.local.words.dtype
        mem.local.words[:] = words.view(np.uint64) if dt == np.uint64 else words.astype(dt)
        if mem.cache is not None:
            c = mem.cache
            o = int(cs[C_CACHE_OFF])
            c.tags[:] = a["ctags"][o:o + len(c.tags)]
        for sp, counts in enumerate(_counters(mem)):
            if counts is _EMPTY:
                continue
            rc = a["rcnt"][p, sp]
            counts.regions = {names[i]: [int(x) for x in rc[i]] for i in range(len(names))
                              if rc[i, 0]}
            pc_ = a["pcnt"][p, sp]
            counts.primitives = {int(i): int(pc_[i]) for i in np.nonzero(pc_)[0]}
    fq, fbt, fbw = a["fq"], a["fbt"], a["fbw"]
    cap = fbt.shape[1]
    for i, f in enumerate(st.fifos):
        h, n = int(fq[i, Q_HEAD]), int(fq[i, Q_CNT])
        f.q = deque((int(fbt[i, (h + k) % cap]), int(fbw[i, (h + k) % cap]) & mask)
                    for k in range(n))
    for i, pe in enumerate(machine.pes):
        for s, stage in enumerate(STAGES):
            m = 3 * i + s
            cmu = pe.ring.cmus[s]
            pe.ring.link_words[stage][0] = int(a["linkw"][m])
            n = len(cmu.inputs)
            cmu.route = [None if r == _ROUTE_NONE else int(r) for r in a["route"][m, :n]]
            cmu.remaining = [int(r) for r in a["rem"][m, :n]]
            cmu.link_owner = [int(o) for o in a["lown"][m, :len(cmu.out_link)]]
        pr = a["pes"][i]
        machine.no_progress[i] = int(pr[P_NO_PROGRESS])
    d = machine.dis
    d.current = [int(x) for x in a["dcur"]]
    d.offset = [int(x) for x in a["doff"]]
    d.upcoming = [int(x) for x in a["dup"]]
    d.assigned = [int(x) for x in a["dasg"]]
    col = machine.col
    col.partial = [[int(w) & mask for w in a["cpart"][i, :a["cplen"][i]]]
                   for i in range(len(machine.pes))]
