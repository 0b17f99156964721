"""Loops as a kernel writer sees them: natural loops found by dominators, nested into a tree.

A back edge is a branch or jump from bundle n to a bundle h that dominates n (every path from the
program's entry to n passes h); its natural loop is h and every bundle that reaches n without
passing h (the dragon book's construction, as LLVM's LoopInfo and perf's reports show loops).
Back edges to one header make one loop. Loops nest when one's body holds the other's header; a
loop's parent is the smallest loop around it. A jump to a bundle that does not dominate it (an
entry into the middle of a loop) makes no loop: that is a goto, not a loop.

The flow graph is per bundle: a bundle with a conditional branch goes to its target and falls
through; a jump goes to its target only; a `jr` to every code address an `li` puts in its
register anywhere in the program (the kernels' `li p_vhead, poly_vtx_r ... jr p_vhead`);
`halt` and `ret` end a path; a `call` falls through (its subroutine returns there). Code no
path from the entry reaches (a subroutine) is entered at its first bundle, in address order, as
a graph of its own, so its loops are found too.

A loop is named by the label at its header; a header without one (a software-pipelined loop's
kernel, whose label moved to the guard) takes the nearest label before it when no other loop is
headed there and no earlier loop took that name — so one loop has one name (`loop`) in the
pipelining information, `report bounds`, `report annotate` and the debugger's `info loop` —
else `label+N`.

`report annotate`, `report bounds`, `asm --bounds` and `info loop` all take their loops from
here: from a program (`program_loops`) or from a statistics file's listing (`listing_loops`).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Sequence

from netsushisen.isa.opcodes import OPCODES

ENDS = ("halt", "ret", "jumpr")
"""Control kinds after which no known bundle follows."""


@dataclass(frozen=True)
class Flow:
    """One bundle's control: the code address its branch or jump names (None without one) and
    the kind of its control operation ("" without one)."""

    target: int | None
    kind: str
    targets: tuple[int, ...] = ()
    """A `jr`'s possible targets: the code addresses `li` puts in its register anywhere."""


@dataclass(frozen=True)
class Loop:
    """A natural loop: its header, its bundles, the bundles with its back edges, its name and
    the index of its parent in the list (None: outermost) and its depth (1: outermost)."""

    header: int
    body: tuple[int, ...]
    latches: tuple[int, ...]
    name: str
    parent: int | None
    depth: int
    members: frozenset[int] = field(default=frozenset(), compare=False, repr=False)

    def __post_init__(self):
        object.__setattr__(self, "members", frozenset(self.body))

    @property
    def start(self) -> int:
        return self.body[0]

    @property
    def end(self) -> int:
        return self.body[-1]

    def __contains__(self, pc: int) -> bool:
        return pc in self.members

    @property
    def pcs_text(self) -> str:
        """`8-15`: the first and last bundle (a natural loop's body need not be every bundle
        between: its size is the tables' `bundles`)."""
        return f"{self.start}-{self.end}"


def successors(flow: Sequence[Flow]) -> list[list[int]]:
    n = len(flow)
    out = []
    for pc, f in enumerate(flow):
        succ = [t for t in f.targets if 0 <= t < n]
        if f.target is not None and 0 <= f.target < n and f.kind in ("branch", "jump"):
            succ.append(f.target)
        if f.kind not in ("jump",) + ENDS and pc + 1 < n:
            succ.append(pc + 1)
        out.append(list(dict.fromkeys(succ)))
    return out


def dominators(succ: list[list[int]]) -> list[int]:
    """The immediate dominator of every bundle (an entry: itself), by Cooper, Harvey and
    Kennedy's iterative algorithm. Entries in address order: 0, then the first bundle no
    earlier entry reaches, whose region (what it reaches that no earlier entry does) is a
    graph of its own."""
    n = len(succ)
    idom = [-1] * n
    for root in range(n):
        if idom[root] != -1:
            continue
        region = {root}
        order_post: list[int] = []
        stack = [(root, iter(succ[root]))]
        while stack:  # a depth-first search of the new region: its reverse postorder
            node, it = stack[-1]
            nxt = next(it, None)
            if nxt is None:
                stack.pop()
                order_post.append(node)
            elif idom[nxt] == -1 and nxt not in region:
                region.add(nxt)
                stack.append((nxt, iter(succ[nxt])))
        order = order_post[::-1]
        rpo = {node: i for i, node in enumerate(order)}
        preds: dict[int, list[int]] = {node: [] for node in order}
        for a in order:
            for b in succ[a]:
                if b in region:
                    preds[b].append(a)
        local = {root: root}

        def intersect(a: int, b: int) -> int:
            while a != b:
                while rpo[a] > rpo[b]:
                    a = local[a]
                while rpo[b] > rpo[a]:
                    b = local[b]
            return a

        changed = True
        while changed:
            changed = False
            for node in order[1:]:
                done = [p for p in preds[node] if p in local]
                if not done:
                    continue
                new = done[0]
                for p in done[1:]:
                    new = intersect(p, new)
                if local.get(node) != new:
                    local[node] = new
                    changed = True
        for node, d in local.items():
            idom[node] = d
    return idom


def _dominates(idom: list[int], a: int, b: int) -> bool:
    while True:
        if a == b:
            return True
        if idom[b] == b:
            return False
        b = idom[b]


def natural_loops(flow: Sequence[Flow], names: dict[int, str] | None = None) -> list[Loop]:
    """Every natural loop, outermost first (then by header), with its parent and name
    (`names`: code address -> label or `label+N`, as `asm.listing.target_names`)."""
    succ = successors(flow)
    if not succ:
        return []
    idom = dominators(succ)
    preds: list[list[int]] = [[] for _ in succ]
    for a, ss in enumerate(succ):
        for b in ss:
            preds[b].append(a)
    latches: dict[int, list[int]] = {}
    for a, ss in enumerate(succ):
        for h in ss:
            if _dominates(idom, h, a):
                latches.setdefault(h, []).append(a)
    bodies: dict[int, set[int]] = {}
    for h, ls in latches.items():
        body = {h}
        stack = [x for x in ls if x != h]
        body.update(stack)
        while stack:
            x = stack.pop()
            for p in preds[x]:
                if p not in body:
                    body.add(p)
                    stack.append(p)
        bodies[h] = body
    headers = sorted(bodies, key=lambda h: (-len(bodies[h]), h))
    parent_of: dict[int, int | None] = {}
    for h in headers:
        around = [o for o in headers if o != h and h in bodies[o]
                  and len(bodies[o]) >= len(bodies[h])]
        parent_of[h] = min(around, key=lambda o: (len(bodies[o]), o)) if around else None
    depth: dict[int, int] = {}
    for h in headers:  # parents come first: larger bodies first
        depth[h] = 1 if parent_of[h] is None else depth[parent_of[h]] + 1
    ordered = sorted(headers, key=lambda h: (depth[h], h))
    index = {h: i for i, h in enumerate(ordered)}
    named = _names(ordered, names or {})
    return [Loop(h, tuple(sorted(bodies[h])), tuple(sorted(latches[h])), named[h],
                 None if parent_of[h] is None else index[parent_of[h]], depth[h])
            for h in ordered]


def _names(headers: list[int], names: dict[int, str]) -> dict[int, str]:
    """The header's label; else the nearest label before it, when no loop is headed there and
    no earlier loop took it; else `label+N` (or the address)."""
    out: dict[int, str] = {}
    taken = {names[h] for h in headers if h in names and "+" not in names[h]}
    for h in sorted(headers):
        name = names.get(h, str(h))
        base, plus, _ = name.partition("+")
        if plus and base not in taken:
            name = base
            taken.add(base)
        out[h] = name
    return out


def innermost(loops: list[Loop], pc: int) -> Loop | None:
    """The deepest loop whose body holds `pc` (None: not in a loop)."""
    inside = [lp for lp in loops if pc in lp]
    return max(inside, key=lambda lp: (lp.depth, -len(lp.body)), default=None)


def chain(loops: list[Loop], loop: Loop) -> list[Loop]:
    """The loop and its ancestors, innermost first."""
    out = [loop]
    while out[-1].parent is not None:
        out.append(loops[out[-1].parent])
    return out


def program_flow(program) -> list[Flow]:
    """Every bundle's control (`Flow`) from an assembled program."""
    from netsushisen.asm.listing import bundle_target

    loaded: dict[int, set[int]] = {}
    for bundle in program.bundles:
        for op in bundle:
            if op.opcode.mnemonic == "li" and isinstance(op.args[1], int):
                loaded.setdefault(op.args[0], set()).add(op.args[1])
    out = []
    for bundle in program.bundles:
        control = next((op for op in bundle if op.opcode.is_control), None)
        kind = control.opcode.kind if control is not None else ""
        targets = tuple(sorted(loaded.get(control.args[0], ()))) if kind == "jumpr" else ()
        out.append(Flow(bundle_target(bundle), kind, targets))
    return out


def program_loops(program) -> list[Loop]:
    """The natural loops of an assembled program, named by its labels."""
    from netsushisen.asm.listing import target_names

    return natural_loops(program_flow(program), target_names(program))


def _ops(text: str | None) -> list[tuple[str, list[str]]]:
    """(mnemonic, operands) of each operation of a listing text (`ldr r2, [r1] ; blt r1, r9, x`)."""
    out = []
    for part in (text or "").split(" ; "):
        mnemonic, _, rest = part.strip().partition(" ")
        out.append((mnemonic, [a.strip() for a in rest.split(",")]))
    return out


def listing_loops(labels: Sequence[str], texts: Sequence[str | None],
                  targets: Sequence[int | None]) -> list[Loop]:
    """The natural loops of a statistics file's listing (its label, text and target columns)."""
    address = {name: pc for pc, name in enumerate(labels)}
    loaded: dict[str, set[int]] = {}
    for text in texts:
        for mnemonic, args in _ops(text):
            if mnemonic == "li" and len(args) == 2:
                value = address.get(args[1])
                if value is None and args[1].lstrip("-").isdigit():
                    value = int(args[1])
                if value is not None:
                    loaded.setdefault(args[0], set()).add(value)
    flow = []
    for text, target in zip(texts, targets):
        kind, jr_targets = "", ()
        for mnemonic, args in _ops(text):
            op = OPCODES.get(mnemonic)
            if op is not None and op.is_control:
                kind = op.kind
                if kind == "jumpr":
                    jr_targets = tuple(sorted(loaded.get(args[0], ())))
        flow.append(Flow(target, kind, jr_targets))
    return natural_loops(flow, dict(enumerate(labels)))
