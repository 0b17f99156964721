"""Linear assembly: a `.sched` ... `.endsched` region's operations into bundles.

The region is cut into blocks — a label starts one, a control transfer or halt ends one — and
each block is list-scheduled (asm/scheduler.py); a block that a `.pipeline` label heads and whose
last operation branches back to that label is software-pipelined (asm/pipeline.py), or
list-scheduled with the reason it could not be. The result is a `Layout` of region-local
operation indices (renamed where pipelined) that the assembler turns into bundles.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from netsushisen.asm.checker import check_bundle
from netsushisen.asm.dependences import dependences, ends_block
from netsushisen.asm.objects import Op, SourceLoc
from netsushisen.asm.parser import Directive, Loc
from netsushisen.isa.errors import Diagnostic
from netsushisen.asm.pipeline import Layout, Placed, PipelineReport, materialize, pipeline_loop
from netsushisen.asm.scheduler import list_schedule
from netsushisen.isa.config import MachineConfig
from netsushisen.isa.processors import Processor


@dataclass
class RegionLoop:
    """A `.pipeline` mark: the region-local index of the loop's head and how to name it."""

    head: int
    name: str
    where: str


@dataclass
class Region:
    """A `.sched` ... `.endsched` region: pending bundles first..end (one operation each)."""

    loc: Loc
    first: int
    end: int = -1
    starts: set[int] = field(default_factory=set)  # region-local indices labels point at
    loops: list[RegionLoop] = field(default_factory=list)
    temps: list[int] = field(default_factory=list)
    inorder: bool = False  # `.sched inorder`: resident and global loads keep their order
    deadout: list[int] = field(default_factory=list)  # `.deadout`: dead at every exit
    temps_auto: bool = False  # `.temps auto`: every register no physical name uses
    vregs: dict[str, Loc] = field(default_factory=dict)  # `.vreg` names the assembler allocates


MAX_REGION_OPS = 2048
"""Operations of one `.sched` region (2,048): far more than a kernel's hot code (the bundled
kernels' largest region has a few hundred); a longer one is refused at the line that passes it,
while the source is read, so a generated 50,000-line region costs seconds, not minutes."""

MAX_REGION_LABELS = 1024
"""Labels inside one `.sched` region (each starts a block the scheduler lays out apart)."""

MAX_SIDE_EXITS = 256
"""Branches inside one `.deadout` superblock (side exits): the scheduler ranks every operation
by the exits after it."""

MAX_PIPELINE_OPS = 128
"""Operations of one `.pipeline` loop: the modulo scheduler tries up to MAX_II_TRIES initiation
intervals, each placing every operation against every row; a longer loop is scheduled as a
plain block, its information saying why (a 300-operation loop took 30 s)."""


def region_problem(region: Region, ops: list[Op]) -> str | None:
    """Why a region is beyond its documented limits before it is scheduled (None if not)."""
    if len(region.starts) > MAX_REGION_LABELS:
        return (f"this .sched region has {len(region.starts):,} labels, more than "
                f"{MAX_REGION_LABELS:,} (asm.regions.MAX_REGION_LABELS): split it")
    if region.deadout:
        exits = sum(1 for op in ops if op.opcode.kind == "branch")
        if exits > MAX_SIDE_EXITS:
            return (f"this .deadout region has {exits:,} side exits, more than "
                    f"{MAX_SIDE_EXITS:,} (asm.regions.MAX_SIDE_EXITS): split it")
    return None


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


def superblocks(spans: list[tuple[int, int]], ops: list[Op], targets: list[int | None],
                starts: set[int], heads: set[int]) -> list[tuple[int, int]]:
    """Blocks joined through the fall-through of a conditional branch out of the region into a
    block no label starts: one superblock, scheduled as one (its branches are side exits). A
    `.pipeline` loop's block stays alone."""
    out: list[tuple[int, int]] = []
    for a, b in spans:
        if out and out[-1][0] not in heads:
            pa, pb = out[-1]
            last = ops[pb - 1]
            if pb == a and a not in starts and last.opcode.kind == "branch" and targets[pb - 1] is None:
                out[-1] = (pa, b)
                continue
        out.append((a, b))
    return out


def schedule_region(ops: list[Op], targets: list[int | None], starts: set[int],
                    loops: list[RegionLoop], temps: list[int], proc: Processor,
                    config: MachineConfig, inorder: bool = False, deadout: list[int] | None = None
                    ) -> tuple[Layout, dict[int, int], list[PipelineReport]]:
    """The region's layout, where each block start (region-local index) lands, and a report per
    `.pipeline` loop. `targets[i]`: the region-local index operation i branches to, if inside.
    `inorder`: resident and global loads keep their serial order (`.sched inorder`); `deadout`:
    registers dead at every exit of the region, which makes superblocks (`.deadout`)."""
    layout = Layout()
    starts_at: dict[int, int] = {}
    reports = []
    heads = {loop.head: loop for loop in loops}
    spans = blocks(len(ops), ops, starts | set(heads))
    dead = frozenset(deadout) if deadout else None
    if dead is not None:
        spans = superblocks(spans, ops, targets, starts | set(heads), set(heads))
    for a, b in spans:
        starts_at[a] = len(layout.bundles)
        body = ops[a:b]
        loop = heads.get(a)
        if loop is not None:
            report = PipelineReport(loop.name, loop.where, 0)
            reports.append(report)
            if targets[b - 1] != a:
                report.ops = len(body)
                report.reason = "it is not a single-block loop (its last operation does not branch back to its head)"
            elif len(body) > MAX_PIPELINE_OPS:
                report.ops = len(body)
                report.reason = (f"{len(body):,} operations, more than {MAX_PIPELINE_OPS} "
                                 "(asm.regions.MAX_PIPELINE_OPS)")
            else:
                sub = pipeline_loop(body, proc, config, temps, report, inorder)
                if sub is not None:
                    prefix = f"{loop.name}."
                    for bundle in sub.bundles:
                        layout.bundles.append([_shift(p, a, prefix) for p in bundle])
                    for name, at in sub.labels.items():
                        layout.labels[prefix + name] = starts_at[a] + at
                    continue
        graph = dependences(body, proc, config, inorder=inorder, deadout=dead)
        for bundle in list_schedule(body, proc, config, graph):
            layout.bundles.append([Placed(a + i) for i in bundle])
    starts_at[len(ops)] = len(layout.bundles)
    return layout, starts_at, reports


def _shift(p: Placed, offset: int, prefix: str) -> Placed:
    return Placed(p.index + offset if p.index >= 0 else -1, p.reads, p.writes, p.mnemonic,
                  prefix + p.target if p.target else "", p.op,
                  p.source + offset if p.source >= 0 else -1)


def _names(expr):
    from netsushisen.asm.expressions import names_in

    return names_in(expr)


def _word(a) -> str | None:
    """A directive argument that is a bare name (`inorder`), else None."""
    return a.value[1] if a.kind == "expr" and a.value[0] == "name" else None


class RegionAssembly:
    """The assembler's handling of `.sched` regions (a mixin of `assembler.Assembler`, as
    `macros.MacroExpansion` is: it uses its state `st`, `config`, `_resolve_ops`)."""

    def _sched_directive(self, d: Directive) -> None:
        """`.sched`, `.endsched`, `.pipeline`, `.temps`, `.deadout` (docs/scheduling.md)."""
        st = self.st
        name, args = d.name, d.args
        inorder = name == "sched" and len(args) == 1 and _word(args[0]) == "inorder"
        if name == "vreg":
            self._vreg(d)
            return
        if name not in ("temps", "deadout") and args and not inorder:
            st.error(f".{name} takes no arguments" if name != "sched" else
                     ".sched takes no argument but `inorder` (resident and global loads keep "
                     "their order)", d.loc)
            return
        if name == "sched":
            if st.region is not None:
                st.error(f".sched inside a .sched region (opened at line {st.region.loc.line})", d.loc)
                return
            st.region = Region(d.loc, len(st.bundles), inorder=inorder)
            st.regions.append(st.region)
            return
        if st.region is None:
            st.error(f".{name} outside a .sched region", d.loc)
            return
        if name == "endsched":
            if st.pipeline_mark is not None:
                st.error(".pipeline must be followed by the loop's label", st.pipeline_mark)
                st.pipeline_mark = None
            st.region.end = len(st.bundles)
            for pinned in [n for n, (_, loc) in st.aliases.items() if loc in self.pinned]:
                self._unbind(pinned)  # a pinned .vreg is the region's
            st.region = None
        elif name == "pipeline":
            st.pipeline_mark = d.loc
        else:  # temps / deadout: rA-rB or registers, comma-separated
            into = st.region.temps if name == "temps" else st.region.deadout
            if not args:
                st.error(f".{name} takes registers: .{name} r40-r47 or .{name} r40, r41", d.loc)
            if name == "temps" and len(args) == 1 and _word(args[0]) == "auto":
                st.region.temps_auto = True
                return
            for a in args:
                regs = self._temps_arg(a)
                if regs is None:
                    st.error(f".{name} takes registers: rA-rB (a range) or rA", a.loc)
                    continue
                into.extend(r for r in regs if r not in into)

    def _vreg(self, d: Directive) -> None:
        """`.vreg NAME[, NAME ...]`: names the assembler allocates in this region;
        `.vreg NAME = rN`: a name pinned to a register (a value live into or out of it)."""
        from netsushisen.asm.assembler import register_index

        st = self.st
        if st.region is None:
            st.error(".vreg outside a .sched region", d.loc)
            return
        if not d.args:
            st.error(".vreg takes names: .vreg NAME[, NAME ...] or .vreg NAME = rN", d.loc)
        for a in d.args:
            if a.kind == "assign":
                name, expr = a.value
                reg = register_index(expr[1], st.aliases) if expr[0] == "name" else None
                if reg is None:
                    st.error(f".vreg {name} = ... needs a register on the right", a.loc)
                    continue
            elif _word(a) is not None:
                name, reg = _word(a), None
            else:
                st.error(".vreg takes names: .vreg NAME[, NAME ...] or .vreg NAME = rN", a.loc)
                continue
            if register_index(name) is not None or name in st.symbols:
                st.error(f"'{name}' is already a register or a symbol", a.loc)
            elif name in st.aliases or name in st.region.vregs:
                st.error(f"'{name}' is already a register name here", a.loc)
            elif reg is None:
                st.region.vregs[name] = a.loc
            else:
                self._bind(name, reg, a.loc)
                self.pinned.append(a.loc)

    def _allocate_regions(self) -> None:
        """Registers for every region's `.vreg` names (asm/allocation.py), written into the
        names each of its operations resolves with; a pool too small is a located error."""
        from netsushisen.asm.aliasing import successors
        from netsushisen.asm.allocation import Pressure, allocate, liveness, pool_text
        from netsushisen.isa.opcodes import OPCODES
        from netsushisen.isa.processors import N_REGISTERS, ZERO_REGISTER

        st = self.st
        used = self._physical_registers()
        for r in st.regions:
            if r.temps_auto:
                r.temps = [x for x in range(1, N_REGISTERS - 1) if x not in used]
            if not r.vregs or r.end <= r.first:
                continue
            reads, writes, kinds, targets = [], [], [], []
            for pb in st.bundles[r.first:r.end]:
                instr = pb.instrs[0]
                opcode = OPCODES.get(instr.mnemonic)
                rs, ws = set(), set()
                target = None
                for spec, o in zip(opcode.operands if opcode else (), instr.operands):
                    names = {n for n, _ in _names(o.expr) if n in r.vregs}
                    (ws if spec.kind == "rd" else rs).update(names)
                    if spec.kind == "label" and o.expr[0] == "name":
                        sym = st.symbols.get(o.expr[1])
                        if sym is not None and sym.kind == "text" and r.first <= sym.value < r.end:
                            target = int(sym.value) - r.first
                reads.append(rs)
                writes.append(ws)
                kinds.append(opcode.kind if opcode and opcode.is_control else "")
                targets.append(target)
            succ = successors(kinds, targets)
            entry = sorted(set().union(*reads) - set().union(*writes))
            live_in, _ = liveness(reads, writes, succ)
            for name in sorted(live_in[0] | set(entry)):
                st.error(f".vreg {name} is read before it is written (a value live into the "
                         f"region stays physical: .reg, or .vreg {name} = rN)", r.vregs[name])
            if live_in[0] or entry:
                continue
            pool = [x for x in r.temps if x != ZERO_REGISTER]
            result = allocate(reads, writes, succ, pool)
            if isinstance(result, Pressure):
                instr = st.bundles[r.first + result.at].instrs[0]
                first = next((n for o in instr.operands for n, _ in _names(o.expr)), "")
                st.error(f"{len(result.live)} values live at {instr.mnemonic} {first} (pool "
                         f".temps {pool_text(pool) or 'empty'} has {len(pool)}): "
                         f"{' '.join(result.live)}", instr.loc)
                continue
            for k in range(r.first, r.end):
                pb = st.bundles[k]
                pb.aliases = {**pb.aliases, **{n: (reg, r.vregs[n]) for n, reg in result.items()}}
            for n, reg in result.items():
                st.reg_scopes.append([n, reg, r.first, r.end])
            r.temps = [x for x in r.temps if x not in result.values()]  # the pipeliner's

    def _physical_registers(self) -> set[int]:
        """Every register a physical name or operand of the program uses (`.temps auto`)."""
        from netsushisen.asm.assembler import register_index

        st = self.st
        used = {reg for _, reg, _, _ in st.reg_scopes}
        for pb in st.bundles:
            for instr in pb.instrs:
                for o in instr.operands:
                    for n, _ in _names(o.expr):
                        reg = register_index(n, pb.aliases)
                        if reg is not None:
                            used.add(reg)
        return used

    def _temps_arg(self, a) -> list[int] | None:
        from netsushisen.asm.assembler import register_index

        aliases = self.st.aliases
        if a.kind != "expr":
            return None
        e = a.value
        if e[0] == "name" and register_index(e[1], aliases):
            return [register_index(e[1], aliases)]
        if e[0] == "bin" and e[1] == "sub" and e[2][0] == "name" and e[3][0] == "name":
            lo, hi = register_index(e[2][1], aliases), register_index(e[3][1], aliases)
            if lo and hi and lo <= hi:
                return list(range(lo, hi + 1))
        return None

    def _schedule(self, proc, resolved: list[list[Op]], sources: list[list[SourceLoc]],
                  smap: list[SourceLoc]):
        """Lay the `.sched` regions out as scheduled bundles: schedule each region on the
        serial layout's operations, move every code label to its new address, resolve the
        operations again against the moved labels, and build the bundles."""
        st = self.st
        regions = {r.first: r for r in st.regions if r.end > r.first}
        old_to_new: dict[int, int] = {}
        plan = []
        addr = i = 0
        while i < len(st.bundles):
            r = regions.get(i)
            if r is None:
                old_to_new[i] = addr
                plan.append((i, None, None, addr))
                addr, i = addr + 1, i + 1
                continue
            ops = [resolved[k][0] for k in range(r.first, r.end)]
            problem = region_problem(r, ops)
            if problem:
                from netsushisen.asm.assembler import AssemblyError

                raise AssemblyError(Diagnostic(problem, r.loc.file, r.loc.line, r.loc.col))
            self.region_lines |= {(s.file, s.line, s.via) for k in range(r.first, r.end)
                                  for s in sources[k]}
            targets = []
            for op in ops:
                t = next((a for o, a in zip(op.opcode.operands, op.args) if o.kind == "label"), None)
                targets.append(t - r.first if t is not None and r.first <= t < r.end else None)
            layout, starts_at, reports = schedule_region(ops, targets, r.starts, r.loops, r.temps,
                                                         proc, self.config, r.inorder, r.deadout)
            self.pipeline_reports.extend(reports)
            for local, off in starts_at.items():
                old_to_new.setdefault(r.first + local, addr + off)
            plan.append((i, r, layout, addr))
            addr, i = addr + len(layout.bundles), r.end
        old_to_new.setdefault(len(st.bundles), addr)
        for sym in st.symbols.values():
            if sym.kind == "text":
                sym.value = old_to_new[int(sym.value)]
        final = self._resolve_ops(proc, addr)
        bundles: list[tuple[Op, ...]] = []
        op_sources: list[tuple[SourceLoc, ...]] = []
        new_smap: list[SourceLoc] = []
        for i, r, layout, at in plan:
            if r is None:
                bundles.append(tuple(final[i]))
                op_sources.append(tuple(sources[i]))
                new_smap.append(smap[i])
                continue
            ops = [final[k][0] for k in range(r.first, r.end)]
            for bundle in layout.bundles:
                made, srcs, first = [], [], None
                for p in bundle:
                    op = materialize(p, ops)
                    if p.target:
                        target = at + layout.labels[p.target]
                        op = Op(op.mnemonic, tuple(target if o.kind == "label" else a
                                                   for o, a in zip(op.opcode.operands, op.args)))
                    made.append(op)
                    k = r.first + (p.index if p.index >= 0 else p.source)
                    srcs.append(sources[k][0])
                    first = k if first is None else min(first, k)
                for problem in check_bundle(proc, made):
                    st.error(f"internal error: the scheduler made a bundle that breaks a rule: "
                             f"{problem}", r.loc)
                bundles.append(tuple(made))
                op_sources.append(tuple(srcs))
                new_smap.append(smap[first])  # the bundle's earliest source line
        spans = [(r.first, r.end, at, at + len(layout.bundles))
                 for _, r, layout, at in plan if r is not None]

        def moved(i: int, end: bool) -> int:
            """Serial bundle index -> its address after scheduling (a region's first and end
            map to the scheduled region's; `end`: the index ends a range)."""
            for first, stop, new, new_end in spans:
                if first < i < stop or (i == first and not end):
                    return new_end if end else new
            return old_to_new.get(i, addr)

        return bundles, op_sources, new_smap, moved
