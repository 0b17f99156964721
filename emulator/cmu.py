"""FIFOs, links and the CMU ring of one PE (the paper's CMU; header format in isa/ring.py).

FIFO rule (every FIFO, link channel included)
---------------------------------------------
A FIFO has a capacity in words and a delay d: a word pushed in cycle c can be popped in cycle
c + d at the earliest (d = 1 for processor, host and COL FIFOs; d = ring.link_latency for a
link channel). A push in cycle c needs a free slot counted from the occupancy at the *start* of
the cycle: free = capacity − occupancy at cycle start − words already pushed this cycle; a slot
freed by a pop in cycle c is reusable from cycle c + 1 (a registered "full" flag). Since words
pushed in cycle c are never poppable in cycle c either, the order in which the components of a
machine are stepped within a cycle does not change any result. `peak` is the largest
(occupancy at cycle start + words pushed in the cycle) seen.

The ring of a PE
----------------
    FIFO              capacity                  producer → consumer
    send.<p>          ring.fifo_depth           processor p (`send ring`) → CMU p
    recv.<p>          ring.fifo_depth           CMU p → processor p (`recv ring`)
    host              ring.fifo_depth           DIS → OS (`recv host`)
    col               ring.fifo_depth           SC (`send col`) → COL
    link.<p>.<k>      ring.link_buffer_words    CMU p → CMU next(p); one channel per buffer
                                                class k (buffer pool on) or a single one (off)
Links go OS→IC, IC→SC, SC→OS; a physical link carries at most one word per cycle, whatever
the class.

CMU p, every cycle (wormhole routing): its inputs are its processor's send FIFO and the channels
of its incoming link; its outputs are its processor's receive FIFO and the channels of its
outgoing link. The first word of a message is its header; at a header the CMU picks the output:
  - from the incoming link: dest == p → the receive FIFO; any other dest → the outgoing link
    (forwarding: IC → OS crosses SC's CMU without using SC);
  - from the send FIFO: always the outgoing link (a message to oneself goes round the ring);
    dest COL on `ring` is a run-time fault (SC sends pixels on its `col` port);
  - outgoing channel = the header's `cls` with the buffer pool on, channel 0 with it off.
The output stays held by that message until its last word has passed (no interleaving of two
messages in a channel or in a receive FIFO). Each output takes at most one word per cycle; an
input moves at most one word per cycle. Inputs are offered in a round-robin order that rotates
by one every cycle (start at input c mod n; inputs are [send FIFO, channel 0, channel 1, ...]).
The first input that can move takes the output.

Buffer pool. With `ring.buffer_pool = true` every link has one channel per buffer class (the
header's 4-bit `cls`), each with its own buffers and its own wormhole lock, so a message that
waits (for space downstream, or because its sender has not sent its tail yet) blocks only its
own class. Kernels avoid routing deadlock by giving messages that take different routes
different classes (e.g. one class per source→destination pair): then no channel is shared by two
routes and the channels' wait-for graph has no cycle. With the pool off, all classes share one
channel per link and a message stalled mid-way holds the link for everyone — the deadlock
detector (machine.py) then reports it. Protocol deadlocks (every processor blocked sending,
none receiving) are not prevented by the pool.
"""

from __future__ import annotations

from collections import deque

from netsushisen.isa.config import MachineConfig
from netsushisen.isa.ring import DESTS, N_CLASSES, parse_header
from netsushisen.isa.processors import STAGES

NEXT = {"os": "ic", "ic": "sc", "sc": "os"}
PREV = {v: k for k, v in NEXT.items()}


class Fifo:
    """A bounded FIFO of raw words with a delay (see the module docstring)."""

    __slots__ = ("name", "capacity", "delay", "q", "pop_cycle", "pops", "peak", "total")

    def __init__(self, name: str, capacity: int, delay: int = 1):
        self.name = name
        self.capacity = capacity
        self.delay = delay
        self.q: deque[tuple[int, int]] = deque()  # (first cycle it may be popped, word)
        self.pop_cycle = -1  # the cycle of the last pop, and the pops made in it
        self.pops = 0
        self.peak = 0
        self.total = 0  # words ever pushed

    def __len__(self) -> int:
        return len(self.q)

    def free(self, c: int) -> int:
        """Slots a push in cycle c may still use."""
        return self.capacity - len(self.q) - (self.pops if self.pop_cycle == c else 0)

    def ready(self, c: int) -> bool:
        return bool(self.q) and self.q[0][0] <= c

    def visible(self, c: int) -> int:
        """Words poppable in cycle c (what `poll` reports)."""
        n = 0
        for t, _ in self.q:
            if t > c:
                break
            n += 1
        return n

    def head(self) -> int:
        return self.q[0][1]

    def push(self, c: int, word: int) -> None:
        self.q.append((c + self.delay, word))
        self.total += 1
        occupancy = len(self.q) + (self.pops if self.pop_cycle == c else 0)
        if occupancy > self.peak:
            self.peak = occupancy

    def pop(self, c: int) -> int:
        if self.pop_cycle != c:
            self.pop_cycle, self.pops = c, 0
        self.pops += 1
        return self.q.popleft()[1]

    def words(self) -> list[int]:
        return [w for _, w in self.q]


class RingFault(Exception):
    """A message the ring cannot route (the machine reports it as a run-time fault)."""


def col_on_ring(stage: str, header: int) -> str:
    """The fault message of a pixel message sent on the ring instead of SC's `col` port."""
    return (f"CMU {stage}: message header {header:#x} for COL sent on the ring (SC sends pixels "
            "on `col`)")


class Cmu:
    """The communication unit of stage `stage` (see the module docstring)."""

    def __init__(self, stage: str, send: Fifo, recv: Fifo, in_link: list[Fifo],
                 out_link: list[Fifo], pooled: bool, in_count: list[int], out_count: list[int]):
        self.stage = stage
        # words in the incoming / outgoing link (all channels): a shared counter with the
        # neighbouring CMU, so an idle CMU costs one test per cycle
        self.in_count, self.out_count = in_count, out_count
        self.dest_id = DESTS[stage]
        self.inputs: list[Fifo] = [send, *in_link]
        self.recv = recv
        self.out_link = out_link
        self.pooled = pooled
        n = len(self.inputs)
        # wormhole state, per input: output held (-1: recv FIFO, k >= 0: outgoing channel k,
        # None: at a message boundary) and payload words still to pass
        self.route: list[int | None] = [None] * n
        self.remaining = [0] * n
        # owner (input index) of each output, or -1
        self.recv_owner = -1
        self.link_owner = [-1] * len(out_link)
        self.moved = 0  # words moved (progress for the deadlock detector)

    def step(self, c: int) -> bool:
        """Move words for cycle c; True if any moved."""
        inputs = self.inputs
        n = len(inputs)
        if self.in_count[0] == 0:
            if not inputs[0].q:
                return False
            candidates: list[int] | tuple[int, ...] = (0,)
        else:  # the inputs holding words, in round-robin order from input c mod n
            start = c % n
            candidates = sorted((i for i in range(n) if inputs[i].q), key=lambda i: (i - start) % n)
        recv_free = True
        link_free = True
        moved = False
        for i in candidates:
            f = inputs[i]
            if f.q[0][0] > c:
                continue
            target = self.route[i]
            if target is None:  # a header: choose the output
                h = parse_header(f.q[0][1])
                if i > 0 and h.dest == self.dest_id:
                    target = -1
                else:
                    if i == 0 and h.dest == DESTS["col"]:
                        raise RingFault(col_on_ring(self.stage, f.q[0][1]))
                    target = h.cls if self.pooled else 0
                length = h.length
            else:
                length = -1
            if target == -1:
                if not recv_free or self.recv_owner not in (-1, i) or self.recv.free(c) <= 0:
                    continue
                self.recv.push(c, f.pop(c))
                recv_free = False
            else:
                out = self.out_link[target]
                if not link_free or self.link_owner[target] not in (-1, i) or out.free(c) <= 0:
                    continue
                out.push(c, f.pop(c))
                self.out_count[0] += 1
                link_free = False
            if i:
                self.in_count[0] -= 1
            moved = True
            self.moved += 1
            if length >= 0:  # the header just moved
                self.route[i] = target
                self.remaining[i] = length
                if target == -1:
                    self.recv_owner = i
                else:
                    self.link_owner[target] = i
            else:
                self.remaining[i] -= 1
            if self.remaining[i] == 0:  # the tail has passed: release the output
                self.route[i] = None
                if target == -1:
                    self.recv_owner = -1
                else:
                    self.link_owner[target] = -1
            if not recv_free and not link_free:
                break
        return moved

    def describe_locks(self) -> list[str]:
        out = []
        names = [f.name for f in self.inputs]
        if self.recv_owner >= 0:
            i = self.recv_owner
            out.append(f"recv.{self.stage} held by a message from {names[i]} "
                       f"({self.remaining[i]} words to come)")
        for k, owner in enumerate(self.link_owner):
            if owner >= 0:
                out.append(f"{self.out_link[k].name} held by a message from {names[owner]} "
                           f"({self.remaining[owner]} words to come)")
        return out


class Ring:
    """All FIFOs, links and CMUs of one PE."""

    def __init__(self, config: MachineConfig, pe: int):
        rc = config.ring
        d = rc.fifo_depth
        pre = f"pe{pe}."
        self.pooled = rc.buffer_pool
        n_channels = N_CLASSES if rc.buffer_pool else 1
        self.send = {s: Fifo(f"{pre}send.{s}", d) for s in STAGES}
        self.recv = {s: Fifo(f"{pre}recv.{s}", d) for s in STAGES}
        self.host = Fifo(f"{pre}host", d)
        self.col = Fifo(f"{pre}col", d)
        self.links = {s: [Fifo(f"{pre}link.{s}-{NEXT[s]}" + (f".{k}" if rc.buffer_pool else ""),
                               rc.link_buffer_words, rc.link_latency) for k in range(n_channels)]
                      for s in STAGES}
        self.link_words = {s: [0] for s in STAGES}  # words in each link (all channels)
        self.cmus = [Cmu(s, self.send[s], self.recv[s], self.links[PREV[s]], self.links[s],
                         rc.buffer_pool, self.link_words[PREV[s]], self.link_words[s])
                     for s in STAGES]

    def ports(self, stage: str) -> tuple[dict[str, Fifo], dict[str, Fifo]]:
        """(receive ports, send ports) of a processor, by port name."""
        recv = {"ring": self.recv[stage]}
        send = {"ring": self.send[stage]}
        if stage == "os":
            recv["host"] = self.host
        if stage == "sc":
            send["col"] = self.col
        return recv, send

    def step(self, c: int) -> bool:
        moved = False
        for cmu in self.cmus:
            if cmu.step(c):
                moved = True
        return moved

    def fifos(self) -> list[Fifo]:
        """Every FIFO of the PE, in a fixed order (for reports and statistics)."""
        out = [self.host]
        for s in STAGES:
            out += [self.send[s], self.recv[s]]
        out.append(self.col)
        for s in STAGES:
            out += self.links[s]
        return out

    def words_in_flight(self) -> int:
        return sum(len(f) for f in self.fifos())

    def ring_words(self) -> int:
        """Words in the ring proper (send, receive FIFOs and links; not host or col)."""
        n = 0
        for s in STAGES:
            n += len(self.send[s]) + len(self.recv[s])
            for ch in self.links[s]:
                n += len(ch)
        return n
