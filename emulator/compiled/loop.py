"""The compiled engine's machine loop: the reference engine's cycle, line for line, over arrays.

This file is never imported as it stands: `build.py` puts the machine's float type `F`
(numpy.float32 or numpy.float64, a compile-time constant) and the opcode dispatchers it
generates from the opcode table (`exec_alu`, `exec_branch`) in front of this text, writes the
whole into a cache folder named by a hash of everything it depends on, and imports that (so
numba's on-disk cache can never serve code compiled from an older opcode table or loop). Every
rule here is the reference engine's: core.py (T1–T10, the issue checks in their order),
memories.py, cmu.py, machine.py (DIS, COL, end of run); the comments name the reference
function mirrored. State layouts (the index constants) are defined in state.py and passed in as
plain integers.

Where the loop does less than the reference's cycle-by-cycle rule, it is because the skipped
work provably gives the same answer: issue checks that cannot fail (no result in flight, no
unit occupied, ports to spare), processors asleep on their FIFOs (state.py C_SLEEP), processors
run ahead of the machine through bundles that touch only their own state (run_cycles, state.py
C_AHEAD), and quiet cycles skipped at once (skip_quiet) — each charging its counters exactly as
the rule would.
"""

import numpy as np
from numba import njit

from netsushisen.emulator.compiled.bits import as_f, as_i, ctz, word_i
from netsushisen.emulator.compiled.state import (
    B_NOPS, B_NREADS, B_READS, B_NWRITES, B_WRITES, B_NUNITS, B_UNITS, B_NRECVS, B_RECVS, B_NSENDS,
    B_UFIT, B_NWTOTAL, C_BUSYMAX, C_SLEEP, C_RUN_N, C_RUN_PC, C_RUN_CAUSE, Q_RSTAGE, Q_SSTAGE, W_WAKE,
    B_SENDS, B_WAITS, B_LOAD0, B_NWLAT, B_WLAT, B_LATE, B_UNPIPED, O_KIND, O_MN, O_UNIT, O_LAT,
    O_PIPE, O_RD, O_SRC, O_R, O_BASE, O_SPACE, O_PORT, O_TARGET, O_NWRITES, K_ALU, K_LOAD, K_STORE,
    K_BRANCH, K_JUMP, K_JUMPR, K_CALL, K_RET, K_SEND, K_RECV, K_POLL, K_ROOM, K_HALT, C_PC,
    C_HALTED, C_HOLD_UNTIL, C_HOLD_MEM_UNTIL, C_HOLD_CAUSE, C_HOLD_PC, C_CYCLES, C_BUNDLES,
    C_LAST_PC, C_LAST_ISSUED, C_CAUSE, C_PRESENT, C_NB, C_WPORTS, C_PENALTY, C_T_LOCAL, C_T_R,
    C_T_C, C_T_G, C_SEG_LOCAL, C_CACHE_SETS, C_CACHE_OFF, C_BLOCK_BYTES, C_WORD_BYTES,
    C_LOCAL_READS, C_LOCAL_WRITES, C_RES_READS, C_CACHE_ACC, C_CACHE_HITS, C_CACHE_MISSES,
    C_GLOBAL_ACC, C_WAKE, C_WAKE_CAUSE, C_NPEND, C_FIFOWAIT, C_BSHIFT, C_SSHIFT, CAUSE_NONE,
    CAUSE_HALTED, CAUSE_BRANCH, CAUSE_LOCAL, CAUSE_RESIDENT, CAUSE_CACHE_HIT, CAUSE_CACHE_MISS,
    CAUSE_WRITE_PORT, CAUSE_FIFO_ANY, CAUSE_FIFO_EMPTY, CAUSE_FIFO_FULL, CAUSE_OPERAND, CAUSE_WAW,
    CAUSE_UNIT, Q_CAP, Q_DELAY, Q_HEAD, Q_CNT, Q_POPC, Q_POPS, Q_PEAK, Q_TOTAL, Q_PE, Q_RING,
    Q_CSTAGE, Q_CIN, W_ALL, W_RING, W_LASTVIS, W_MASK, M_N, M_RECV_OWNER, M_MOVED, M_RECV, M_DEST,
    M_LINK_IN, M_LINK_OUT, P_MOVED, P_DIS_MOVED, P_COL_MOVED, P_NO_PROGRESS, P_HOST, P_COL,
    D_DYNAMIC, D_NEXT, D_NMSGS, D_WORDS_SENT, L_MESSAGES, L_WORDS, L_WIDTH, L_HEIGHT, G_CYCLE,
    G_DEADLOCK_CYCLES, G_POOLED, G_NPES, G_W, G_STOP_P, G_STOP_PC, S_RUNNING, S_HALTED, S_FINISHED,
    S_DEADLOCK_PE, S_DEADLOCK_COL, S_FAULT, S_STOPPED, F_PC, F_MEMORY, F_RING_COL, F_COL_HEADER,
    F_COL_PIXEL, SP_LOCAL, SP_RESIDENT, S_DEADLOCK_MSG, C_AHEAD, C_AHEAD_ISSUED, C_AHEAD_CAUSE,
    B_PRIVATE, G_AHEAD, C_CACHE_WAYS, C_RECORD,
)
from netsushisen.emulator import cacherule

_OPTS = dict(cache=True, nogil=True, error_model="numpy", boundscheck=False, _nrt=False)
_INLINE = dict(_OPTS, inline="always")  # one function: array arguments are costly to pass

# -- FIFOs (cmu.Fifo) ---------------------------------------------------------------------------


@njit(**_INLINE)
def q_free(fq, q, c):
    return fq[q, Q_CAP] - fq[q, Q_CNT] - (fq[q, Q_POPS] if fq[q, Q_POPC] == c else 0)


@njit(**_INLINE)
def q_ready(fq, fbt, q, c):
    return fq[q, Q_CNT] > 0 and fbt[q, fq[q, Q_HEAD]] <= c


@njit(**_INLINE)
def q_visible(fq, fbt, q, c):
    """The words of FIFO q visible in cycle c: a prefix, since a FIFO's words become visible in
    the order they were pushed (push cycle + the FIFO's constant delay) — so all of them once
    the newest is."""
    cnt = fq[q, Q_CNT]
    wrap = fbt.shape[1] - 1  # capacities are powers of two (state.py)
    h = fq[q, Q_HEAD]
    if cnt == 0 or fbt[q, (h + cnt - 1) & wrap] <= c:
        return cnt
    n = 0
    for k in range(cnt):
        if fbt[q, (h + k) & wrap] > c:
            break
        n += 1
    return n


@njit(**_INLINE)
def q_push(fq, fbt, fbw, pw, q, c, w):
    pe = fq[q, Q_PE]
    pw[pe, W_ALL] += 1
    pw[pe, W_RING] += fq[q, Q_RING]
    if c + fq[q, Q_DELAY] > pw[pe, W_LASTVIS]:
        pw[pe, W_LASTVIS] = c + fq[q, Q_DELAY]
    if fq[q, Q_CSTAGE] >= 0:
        pw[pe, W_MASK + fq[q, Q_CSTAGE]] |= 1 << fq[q, Q_CIN]
    k = (fq[q, Q_HEAD] + fq[q, Q_CNT]) & (fbt.shape[1] - 1)
    fbt[q, k] = c + fq[q, Q_DELAY]
    fbw[q, k] = w
    fq[q, Q_CNT] += 1
    fq[q, Q_TOTAL] += 1
    occ = fq[q, Q_CNT] + (fq[q, Q_POPS] if fq[q, Q_POPC] == c else 0)
    if occ > fq[q, Q_PEAK]:
        fq[q, Q_PEAK] = occ
    s = fq[q, Q_RSTAGE]  # its receiver, if asleep, checks again once the word is visible
    if s >= 0 and c + fq[q, Q_DELAY] < pw[pe, W_WAKE + s]:
        pw[pe, W_WAKE + s] = c + fq[q, Q_DELAY]


@njit(**_INLINE)
def q_pop(fq, fbw, pw, q, c):
    pe = fq[q, Q_PE]
    pw[pe, W_ALL] -= 1
    pw[pe, W_RING] -= fq[q, Q_RING]
    if fq[q, Q_POPC] != c:
        fq[q, Q_POPC] = c
        fq[q, Q_POPS] = 0
    fq[q, Q_POPS] += 1
    h = fq[q, Q_HEAD]
    w = fbw[q, h]
    fq[q, Q_HEAD] = (h + 1) & (fbw.shape[1] - 1)
    fq[q, Q_CNT] -= 1
    if fq[q, Q_CNT] == 0 and fq[q, Q_CSTAGE] >= 0:
        pw[pe, W_MASK + fq[q, Q_CSTAGE]] &= ~(1 << fq[q, Q_CIN])
    s = fq[q, Q_SSTAGE]  # its sender, if asleep, checks again next cycle (one more free slot)
    if s >= 0 and c + 1 < pw[pe, W_WAKE + s]:
        pw[pe, W_WAKE + s] = c + 1
    return w


# -- memories (memories.py) -------------------------------------------------------------------


@njit(**_INLINE)
def count_region(rg, rmap, rdense, rcnt, pcnt, p, space, addr, hit):
    """RegionMap.lookup + RegionCounters.count; hit: -1 none, 0 miss, 1 hit. The address is
    inside the memory (checked before); rdense maps it to its region."""
    if rmap[p, space, 1] <= 0:
        return
    i = rdense[rmap[p, space, 0] + addr]
    if i < 0:
        return
    name = rg[i, 0]
    rcnt[p, space, name, 0] += 1
    if hit == 1:
        rcnt[p, space, name, 1] += 1
    elif hit == 0:
        rcnt[p, space, name, 2] += 1
    prim = rg[i, 1]
    if prim >= 0:
        pcnt[p, space, prim] += 1


@njit(**_INLINE)
def cache_locate(cs, p, addr):
    """memories.Cache.locate (sets > 0): (set, tag), by shifts where sizes are powers of two."""
    b = cs[p, C_BSHIFT]
    block = addr >> b if b >= 0 else (addr * cs[p, C_WORD_BYTES]) // cs[p, C_BLOCK_BYTES]
    sh = cs[p, C_SSHIFT]
    if sh >= 0:
        return block & ((1 << sh) - 1), block >> sh
    sets = cs[p, C_CACHE_SETS]
    return block % sets, block // sets


# the cache rule itself (find a tag in a set, an access with its LRU update): compiled from
# emulator/cacherule.py, the functions the reference engine's memories.Cache calls
cache_find = njit(nogil=True, error_model="numpy", boundscheck=False, inline="always")(
    cacherule.find)
cache_touch = njit(nogil=True, error_model="numpy", boundscheck=False, inline="always")(
    cacherule.touch)


@njit(**_INLINE)
def cache_probe(cs, ctags, p, addr):
    if cs[p, C_CACHE_SETS] == 0:
        return False
    s, tag = cache_locate(cs, p, addr)
    w = cs[p, C_CACHE_WAYS]
    return cache_find(ctags, cs[p, C_CACHE_OFF] + s * w, w, tag) >= 0


# -- one processor's cycle (core.Core.step) -------------------------------------------------------


@njit(**_INLINE)
def stall(cs, stpc, p, cause, pc, k):
    """k stall cycles of one cause at one PC, counted into the processor's run (state.py
    C_RUN_N); the counters get the run when the PC or cause changes."""
    if cs[p, C_RUN_PC] != pc or cs[p, C_RUN_CAUSE] != cause:
        stpc[p, cs[p, C_RUN_PC], cs[p, C_RUN_CAUSE]] += cs[p, C_RUN_N]
        cs[p, C_RUN_N] = 0
        cs[p, C_RUN_PC] = pc
        cs[p, C_RUN_CAUSE] = cause
    cs[p, C_RUN_N] += k
    cs[p, C_CAUSE] = cause
    cs[p, C_LAST_PC] = pc


@njit(**_OPTS)  # rare: a call of its own spares compile time
def flush_stalls(cs, stpc, nproc):
    """Add every processor's pending stall run to the counters (before the loop returns)."""
    for p in range(nproc):
        stpc[p, cs[p, C_RUN_PC], cs[p, C_RUN_CAUSE]] += cs[p, C_RUN_N]
        cs[p, C_RUN_N] = 0


@njit(**_INLINE)
def write_due(cs, regs, wbn, wbr, wbw, p, s):
    """Write the results due in write-back slot s (core.Core.step's `pending.pop(c)`)."""
    n = wbn[p, s]
    if n:
        for k in range(n):
            regs[p, wbr[p, s, k]] = wbw[p, s, k]
        wbn[p, s] = 0
        cs[p, C_NPEND] -= n


@njit(**_INLINE)
def schedule(cs, regs_ready, prod, wbn, wbr, wbw, W, p, rd, word, t, mn):
    if rd <= 0:
        return
    s = t & (W - 1)
    k = wbn[p, s]
    wbr[p, s, k] = rd
    wbw[p, s, k] = word
    wbn[p, s] = k + 1
    cs[p, C_NPEND] += 1
    regs_ready[p, rd] = t
    prod[p, rd] = mn


@njit(**_OPTS)  # rare: a call of its own spares compile time
def memory_fault(finfo, p, pc, space, addr):
    """An access outside a memory: fault code 1 with what the report needs."""
    finfo[0] = F_MEMORY
    finfo[1] = p
    finfo[2] = pc
    finfo[3] = space
    finfo[4] = addr
    return 1


@njit(**_INLINE)
def load_time(cs, ctags, regs, ops, opk, p, pc, j):
    """memories.MemorySystem.access_time of the load in slot j: (cycles, stall cause, address)."""
    addr = as_i(regs[p, ops[p, pc, j, O_BASE]]) + opk[p, pc, j, 1]
    sp = ops[p, pc, j, O_SPACE]
    if sp == SP_LOCAL:
        return cs[p, C_T_LOCAL], CAUSE_LOCAL, addr
    if sp == SP_RESIDENT:
        return cs[p, C_T_R], CAUSE_RESIDENT, addr
    if cache_probe(cs, ctags, p, addr):
        return cs[p, C_T_C], CAUSE_CACHE_HIT, addr
    return cs[p, C_T_G], CAUSE_CACHE_MISS, addr


@njit(**_INLINE)
def issue_checks(c, p, pc, A, W):
    """T10's checks 2–6 for the bundle at pc: the stall cause, or -1 when it can issue. Sets
    the processor's wake cycle (operand, destination, unit) or FIFO wait (see state.py)."""
    (cs, regs, ready, prod, wbn, wbr, wbw, busy, occ, unitn, stpc, bpc, ops, opk, opf, bun, recvq,
     sendq, fq, fbt, fbw, mem, seg, ctags, rg, rmap, rdense, rcnt, pcnt, pw, lrec) = A
    if not cs[p, C_FIFOWAIT]:
        npend = cs[p, C_NPEND]
        # 2. operands (RAW): the source ready last. 2 and 3 pass with no result in flight (a
        # register is not ready only while its result is in flight)
        worst = -1
        worst_t = c
        for k in range(bun[p, pc, B_NREADS] if npend else 0):
            r = bun[p, pc, B_READS + k]
            if ready[p, r] > worst_t:
                worst = r
                worst_t = ready[p, r]
        if worst >= 0:
            cs[p, C_WAKE] = worst_t
            cs[p, C_WAKE_CAUSE] = CAUSE_OPERAND + prod[p, worst] + 1
            return cs[p, C_WAKE_CAUSE]
        # 3. destinations (WAW)
        for k in range(bun[p, pc, B_NWRITES] if npend else 0):
            r = bun[p, pc, B_WRITES + k]
            if ready[p, r] > c:
                cs[p, C_WAKE] = ready[p, r]
                cs[p, C_WAKE_CAUSE] = CAUSE_WAW + prod[p, r] + 1
                return cs[p, C_WAKE_CAUSE]
        # 4. units (all free once the last unpipelined operation is done: state.py B_UFIT)
        fit = c >= cs[p, C_BUSYMAX] and bun[p, pc, B_UFIT]
        for k in range(0 if fit else bun[p, pc, B_NUNITS]):
            u = bun[p, pc, B_UNITS + 2 * k]
            need = bun[p, pc, B_UNITS + 2 * k + 1]
            free = 0
            first = -1
            soonest = 0
            for i in range(unitn[p, u]):
                if busy[p, u, i] <= c:
                    free += 1
                else:
                    if first < 0:
                        first = i
                    if soonest == 0 or busy[p, u, i] < soonest:
                        soonest = busy[p, u, i]
            if free < need:
                cs[p, C_WAKE] = soonest
                cs[p, C_WAKE_CAUSE] = CAUSE_UNIT + occ[p, u, first] + 1
                return cs[p, C_WAKE_CAUSE]
        # 5. write ports: results due per cycle (the other writers' by latency, plus loads');
        # none can be short while the results in flight and this bundle's fit the ports
        wp = cs[p, C_WPORTS]
        if npend + bun[p, pc, B_NWTOTAL] <= wp:
            return fifo_checks(c, p, pc, cs, bun, recvq, sendq, fq, fbt)
        lt0 = -1
        lt1 = -1
        for k in range(2):
            j = bun[p, pc, B_LOAD0 + k]
            if j < 0:
                break
            if ops[p, pc, j, O_NWRITES]:
                t = load_time(cs, ctags, regs, ops, opk, p, pc, j)[0]
                if k == 0:
                    lt0 = t
                else:
                    lt1 = t
        nw = bun[p, pc, B_NWLAT]
        for k in range(nw):
            lat = bun[p, pc, B_WLAT + 2 * k]
            due = bun[p, pc, B_WLAT + 2 * k + 1] + (lt0 == lat) + (lt1 == lat)
            if wbn[p, (c + lat) & (W - 1)] + due > wp:
                return CAUSE_WRITE_PORT
        for k in range(2):
            t = lt0 if k == 0 else lt1
            if t < 0 or (k == 1 and lt0 == t):
                continue
            counted = False
            for k2 in range(nw):
                if bun[p, pc, B_WLAT + 2 * k2] == t:
                    counted = True
            if not counted and wbn[p, (c + t) & (W - 1)] + (lt0 == t) + (lt1 == t) > wp:
                return CAUSE_WRITE_PORT
    return fifo_checks(c, p, pc, cs, bun, recvq, sendq, fq, fbt)


@njit(**_INLINE)
def fifo_checks(c, p, pc, cs, bun, recvq, sendq, fq, fbt):
    """T10's check 6, the FIFOs (a processor that stalls here with nothing in flight re-checks
    only these: C_FIFOWAIT)."""
    cs[p, C_FIFOWAIT] = cs[p, C_NPEND] == 0
    for k in range(bun[p, pc, B_NRECVS]):
        port = bun[p, pc, B_RECVS + 2 * k]
        need = bun[p, pc, B_RECVS + 2 * k + 1]
        q = recvq[p, port]
        have = q_visible(fq, fbt, q, c) if need > 1 else (1 if q_ready(fq, fbt, q, c) else 0)
        if have < need:
            return CAUSE_FIFO_EMPTY + port
    if bun[p, pc, B_WAITS]:
        anyready = False
        for port in range(3):
            q = recvq[p, port]
            if q >= 0 and q_ready(fq, fbt, q, c):
                anyready = True
        if not anyready:
            return CAUSE_FIFO_ANY
    for k in range(bun[p, pc, B_NSENDS]):
        port = bun[p, pc, B_SENDS + 2 * k]
        need = bun[p, pc, B_SENDS + 2 * k + 1]
        if q_free(fq, sendq[p, port], c) < need:
            return CAUSE_FIFO_FULL + port
    cs[p, C_FIFOWAIT] = 0
    return -1


@njit(**_INLINE)
def issue(c, p, pc, A, W, finfo):
    """core.Core._issue: returns 0, or a fault code (finfo filled)."""
    (cs, regs, ready, prod, wbn, wbr, wbw, busy, occ, unitn, stpc, bpc, ops, opk, opf, bun, recvq,
     sendq, fq, fbt, fbw, mem, seg, ctags, rg, rmap, rdense, rcnt, pcnt, pw, lrec) = A
    nops = bun[p, pc, B_NOPS]
    # every load's timing first (access_time has no side effects)
    lt0 = 0
    lc0 = 0
    la0 = 0
    lt1 = 0
    lc1 = 0
    la1 = 0
    for k in range(2):
        j = bun[p, pc, B_LOAD0 + k]
        if j < 0:
            break
        t_, c_, a_ = load_time(cs, ctags, regs, ops, opk, p, pc, j)  # one inlined copy
        if k == 0:
            lt0, lc0, la0 = t_, c_, a_
        else:
            lt1, lc1, la1 = t_, c_, a_
    next_pc = pc + 1
    taken = False
    hold_mem = c + 1
    mem_cause = CAUSE_NONE
    nl = 0
    for j in range(nops):
        kind = ops[p, pc, j, O_KIND]
        mn = ops[p, pc, j, O_MN]
        srd = -1  # the result this operation schedules: register, word, cycle
        sw = 0
        st = 0
        if kind == K_ALU:
            srd = ops[p, pc, j, O_RD]
            sw = exec_alu(mn, regs[p, ops[p, pc, j, O_R]], regs[p, ops[p, pc, j, O_R + 1]],
                          regs[p, ops[p, pc, j, O_R + 2]], opk[p, pc, j, 0], opf[p, pc, j])
            st = c + ops[p, pc, j, O_LAT]
        elif kind == K_LOAD:
            if nl == 0:
                addr, t_acc, cause = la0, lt0, lc0
            else:
                addr, t_acc, cause = la1, lt1, lc1
            nl += 1
            sp = ops[p, pc, j, O_SPACE]
            sg = cs[p, C_SEG_LOCAL + sp]
            if sg < 0 or addr < 0 or addr >= seg[sg, 1]:
                return memory_fault(finfo, p, pc, sp, addr)
            hit = -1
            if sp == SP_LOCAL:
                cs[p, C_LOCAL_READS] += 1
            elif sp == SP_RESIDENT:
                cs[p, C_RES_READS] += 1
            else:
                # Cache.access: count, fill on a miss (LRU)
                cs[p, C_CACHE_ACC] += 1
                hit = 0
                if cs[p, C_CACHE_SETS] > 0:
                    sset, tag = cache_locate(cs, p, addr)
                    w = cs[p, C_CACHE_WAYS]
                    if cache_touch(ctags, cs[p, C_CACHE_OFF] + sset * w, w, tag):
                        hit = 1
                if hit:
                    cs[p, C_CACHE_HITS] += 1
                else:
                    cs[p, C_CACHE_MISSES] += 1
                    cs[p, C_GLOBAL_ACC] += 1
            count_region(rg, rmap, rdense, rcnt, pcnt, p, sp, addr, hit)
            if cs[p, C_RECORD] == 2 or (cs[p, C_RECORD] and sp != SP_LOCAL):  # Engine.record_loads (state.py C_RECORD)
                n = lrec[0] + 1
                lrec[n] = (addr << 18) | (p << 2) | (3 if sp == SP_LOCAL else
                                                      (2 if hit == 1 else 0) | (1 if sp == SP_RESIDENT else 0))
                lrec[0] = n
            srd = ops[p, pc, j, O_RD]
            sw = mem[seg[sg, 0] + addr]
            st = c + t_acc
            if st > hold_mem:
                hold_mem = st
                mem_cause = cause
        elif kind == K_BRANCH:
            if exec_branch(mn, regs[p, ops[p, pc, j, O_R]], regs[p, ops[p, pc, j, O_R + 1]]):
                next_pc = ops[p, pc, j, O_TARGET]
                taken = True
        elif kind == K_JUMP:
            next_pc = ops[p, pc, j, O_TARGET]
            taken = True
        elif kind == K_JUMPR:
            next_pc = as_i(regs[p, ops[p, pc, j, O_SRC]])
            taken = True
        elif kind == K_CALL:
            srd = 63
            sw = word_i(F, pc + 1)
            st = c + ops[p, pc, j, O_LAT]
            next_pc = ops[p, pc, j, O_TARGET]
            taken = True
        elif kind == K_RET:
            next_pc = as_i(regs[p, 63])
            taken = True
        elif kind == K_POLL or kind == K_ROOM:
            port = ops[p, pc, j, O_PORT]
            nv = q_visible(fq, fbt, recvq[p, port], c) if kind == K_POLL \
                else q_free(fq, sendq[p, port], c)
            srd = ops[p, pc, j, O_RD]
            sw = word_i(F, nv)
            st = c + ops[p, pc, j, O_LAT]
        elif kind == K_HALT:
            cs[p, C_HALTED] = 1
        if srd > 0:
            schedule(cs, ready, prod, wbn, wbr, wbw, W, p, srd, sw, st, mn)
    # FIFO operations and stores: after every op has read its operands
    if bun[p, pc, B_LATE]:
        for j in range(nops):
            kind = ops[p, pc, j, O_KIND]
            if kind == K_RECV:
                w = q_pop(fq, fbw, pw, recvq[p, ops[p, pc, j, O_PORT]], c)
                schedule(cs, ready, prod, wbn, wbr, wbw, W, p, ops[p, pc, j, O_RD], w,
                         c + ops[p, pc, j, O_LAT], ops[p, pc, j, O_MN])
            elif kind == K_SEND:
                q_push(fq, fbt, fbw, pw, sendq[p, ops[p, pc, j, O_PORT]], c,
                       regs[p, ops[p, pc, j, O_SRC]])
            elif kind == K_STORE:
                addr = as_i(regs[p, ops[p, pc, j, O_BASE]]) + opk[p, pc, j, 1]
                sg = cs[p, C_SEG_LOCAL]
                if addr < 0 or addr >= seg[sg, 1]:
                    return memory_fault(finfo, p, pc, SP_LOCAL, addr)
                cs[p, C_LOCAL_WRITES] += 1
                mem[seg[sg, 0] + addr] = regs[p, ops[p, pc, j, O_SRC]]
    # occupy unpipelined units for their whole latency
    if bun[p, pc, B_UNPIPED]:
        for j in range(nops):
            if not ops[p, pc, j, O_PIPE]:
                u = ops[p, pc, j, O_UNIT]
                for i in range(unitn[p, u]):
                    if busy[p, u, i] <= c:
                        busy[p, u, i] = c + ops[p, pc, j, O_LAT]
                        occ[p, u, i] = ops[p, pc, j, O_MN]
                        if busy[p, u, i] > cs[p, C_BUSYMAX]:
                            cs[p, C_BUSYMAX] = busy[p, u, i]
                        break
    # counters (operations by unit and mnemonic follow from bpc: state.write_back)
    cs[p, C_BUNDLES] += 1
    bpc[p, pc] += 1
    cs[p, C_LAST_ISSUED] = 1
    cs[p, C_LAST_PC] = pc
    cs[p, C_CAUSE] = CAUSE_HALTED if cs[p, C_HALTED] else CAUSE_NONE
    cs[p, C_PC] = next_pc
    if taken or hold_mem > c + 1:
        hu = c + 1 + cs[p, C_PENALTY] if taken else 0
        cs[p, C_HOLD_UNTIL] = hold_mem if hold_mem > hu else hu
        cs[p, C_HOLD_MEM_UNTIL] = hold_mem
        cs[p, C_HOLD_CAUSE] = mem_cause
        cs[p, C_HOLD_PC] = pc
    return 0


@njit(**_INLINE)
def core_step(c, p, A, W, finfo):
    """core.Core.step: returns 0, or a fault code (finfo filled). A: the state arrays (a tuple,
    so the call stays short enough for numba to inline it)."""
    cs, regs, wbn, wbr, wbw, stpc = A[0], A[1], A[4], A[5], A[6], A[10]
    write_due(cs, regs, wbn, wbr, wbw, p, c & (W - 1))
    cs[p, C_LAST_ISSUED] = 0
    if cs[p, C_HALTED]:
        return 0
    cs[p, C_CYCLES] += 1
    pc = cs[p, C_PC]
    pcx = pc
    if c < cs[p, C_HOLD_UNTIL]:  # 1. a hold from an earlier bundle: its memory cause, then branch
        cause = cs[p, C_HOLD_CAUSE] if c < cs[p, C_HOLD_MEM_UNTIL] else CAUSE_BRANCH
        pcx = cs[p, C_HOLD_PC]
    elif c < cs[p, C_WAKE]:  # still waiting for an operand, destination or unit (state.py)
        cause = cs[p, C_WAKE_CAUSE]
    elif pc < 0 or pc >= cs[p, C_NB]:
        finfo[0] = F_PC
        finfo[1] = p
        finfo[2] = pc
        return 1
    else:
        cause = issue_checks(c, p, pc, A, W)
        if cause < 0:
            return issue(c, p, pc, A, W, finfo)
        stall(cs, stpc, p, cause, pcx, 1)
        if cs[p, C_FIFOWAIT]:
            fall_asleep(c, p, cs, A[16], A[17], A[18], A[19], A[29])
        return 0
    stall(cs, stpc, p, cause, pcx, 1)
    return 0


@njit(**_OPTS)  # once per FIFO wait: a call of its own spares compile time
def fall_asleep(c, p, cs, recvq, sendq, fq, fbt, pw):
    """After a FIFO stall in cycle c with nothing in flight: sleep (state.py C_SLEEP) unless a
    word already pushed to a receive FIFO is not visible yet or a send FIFO was popped this
    cycle — then the checks' answer may change without a push or pop to wake it."""
    wrap = fbt.shape[1] - 1
    for port in range(3):
        q = recvq[p, port]
        if q >= 0 and fq[q, Q_CNT] and fbt[q, (fq[q, Q_HEAD] + fq[q, Q_CNT] - 1) & wrap] > c:
            return
        q = sendq[p, port]
        if q >= 0 and fq[q, Q_POPC] == c:
            return
    cs[p, C_SLEEP] = c + 1
    pw[p // 3, W_WAKE + p % 3] = 1 << 62


@njit(**_INLINE)
def wake(cs, stpc, p, upto):
    """Charge a sleeping processor's cycles up to cycle `upto` (exclusive) to its stall, as
    stepping it each cycle would have, and wake it."""
    cs[p, C_CYCLES] += upto - cs[p, C_SLEEP]
    stall(cs, stpc, p, cs[p, C_CAUSE], cs[p, C_LAST_PC], upto - cs[p, C_SLEEP])
    cs[p, C_SLEEP] = 0


@njit(**_OPTS)  # rare: a call of its own spares compile time
def wake_all(cs, stpc, nproc, c, stepped):
    """Before the loop returns in (or after) cycle c: every sleeping processor charged through
    cycle c if it was stepped in it (index < stepped), else through c − 1."""
    for p in range(nproc):
        if cs[p, C_AHEAD]:
            ahead_end(cs, p)
        elif cs[p, C_SLEEP]:
            wake(cs, stpc, p, c + 1 if p < stepped else c)


@njit(**_INLINE)
def hold_through(t, p, until, A, W):
    """Processor p, held in cycle t (by an earlier bundle's branch or load: C_HOLD_UNTIL; or
    waiting for an operand, a destination or a unit: C_WAKE), stays so with the same cause
    until the hold's memory part ends, the hold ends or the wake cycle comes: charge those
    cycles at once as core_step would one by one, write the results that fall due meanwhile,
    and return the first cycle after them."""
    cs, regs, wbn, wbr, wbw, stpc = A[0], A[1], A[4], A[5], A[6], A[10]
    if t < cs[p, C_HOLD_UNTIL]:
        pcx = cs[p, C_HOLD_PC]
        if t < cs[p, C_HOLD_MEM_UNTIL]:
            cause = cs[p, C_HOLD_CAUSE]
            end = cs[p, C_HOLD_MEM_UNTIL]
        else:
            cause = CAUSE_BRANCH
            end = cs[p, C_HOLD_UNTIL]
    else:
        pcx = cs[p, C_PC]
        cause = cs[p, C_WAKE_CAUSE]
        end = cs[p, C_WAKE]
    if end > until:
        end = until
    last = end - 1 if end - 1 < t + W - 1 else t + W - 1
    if cs[p, C_NPEND]:
        for u in range(t, last + 1):
            write_due(cs, regs, wbn, wbr, wbw, p, u & (W - 1))
    cs[p, C_LAST_ISSUED] = 0
    cs[p, C_CYCLES] += end - t
    stall(cs, stpc, p, cause, pcx, end - t)
    return end


@njit(**_INLINE)
def ahead_end(cs, p):
    """A processor that ran ahead is back in step with the machine (its cycles are charged)."""
    cs[p, C_LAST_ISSUED] = cs[p, C_AHEAD_ISSUED]
    cs[p, C_CAUSE] = cs[p, C_AHEAD_CAUSE]
    cs[p, C_AHEAD] = 0
    cs[p, C_SLEEP] = 0


# -- the CMU (cmu.Cmu.step) -------------------------------------------------------------------


@njit(**_INLINE)
def cmu_step(c, start, m, cm, cin, cout, route, rem, lown, linkw, fq, fbt, fbw, pw, pooled,
             finfo):
    """Returns 1 if a word moved, 0 if none, -1 on a fault (finfo filled)."""
    # the inputs holding words (a bit each), offered in round-robin order from input c mod n
    mask = pw[m // 3, W_MASK + m % 3]
    if mask == 0:
        return 0
    n = cm[m, M_N]
    lin = cm[m, M_LINK_IN]
    lout = cm[m, M_LINK_OUT]
    recv_free = True
    link_free = True
    moved = 0
    recv = cm[m, M_RECV]
    rot = ((mask >> start) | (mask << (n - start))) & ((1 << n) - 1)  # bit j: input start + j
    while rot:
        i = start + ctz(rot)
        rot &= rot - 1
        if i >= n:
            i -= n
        f = cin[m, i]
        if fbt[f, fq[f, Q_HEAD]] > c:
            continue
        target = route[m, i]
        if target == -2:  # a header: choose the output
            hw = fbw[f, fq[f, Q_HEAD]] & 0xFFFFFFFF
            length = hw & 255
            dest = (hw >> 8) & 3
            cls = (hw >> 10) & 15
            if i > 0 and dest == cm[m, M_DEST]:
                target = -1
            else:
                if i == 0 and dest == 3:
                    finfo[0] = F_RING_COL
                    finfo[1] = m
                    finfo[2] = fbw[f, fq[f, Q_HEAD]]
                    return -1
                target = cls if pooled else 0
        else:
            length = -1
        if target == -1:
            if not recv_free or (cm[m, M_RECV_OWNER] != -1 and cm[m, M_RECV_OWNER] != i) \
                    or q_free(fq, recv, c) <= 0:
                continue
            dst = recv
            recv_free = False
        else:
            dst = cout[m, target]
            if not link_free or (lown[m, target] != -1 and lown[m, target] != i) \
                    or q_free(fq, dst, c) <= 0:
                continue
            linkw[lout] += 1
            link_free = False
        q_push(fq, fbt, fbw, pw, dst, c, q_pop(fq, fbw, pw, f, c))
        if i:
            linkw[lin] -= 1
        moved = 1
        cm[m, M_MOVED] += 1
        if length >= 0:
            route[m, i] = target
            rem[m, i] = length
            if target == -1:
                cm[m, M_RECV_OWNER] = i
            else:
                lown[m, target] = i
        else:
            rem[m, i] -= 1
        if rem[m, i] == 0:
            route[m, i] = -2
            if target == -1:
                cm[m, M_RECV_OWNER] = -1
            else:
                lown[m, target] = -1
        if not recv_free and not link_free:
            break
    return moved


# -- the whole machine (machine.Machine.step, Dis.step, Col.step, _check_end) --------------------


@njit(**_INLINE)
def ring_words(pe, pw):
    """cmu.Ring.ring_words: send, receive FIFOs and links of a PE."""
    return pw[pe, W_RING]


@njit(**_INLINE)
def core_idle(cs, stpc_flags, p):
    """core.Core.idle: halted, or waiting on an empty receive FIFO."""
    return cs[p, C_HALTED] or (not cs[p, C_LAST_ISSUED] and stpc_flags[cs[p, C_CAUSE]] == 2)


@njit(**_INLINE)
def pe_idle(pe, cs, cflags, pw):
    for s in range(3):
        p = pe * 3 + s
        if cs[p, C_PRESENT] and not core_idle(cs, cflags, p):
            return False
    return pw[pe, W_ALL] == 0


@njit(**_INLINE)
def pe_issued(pe, cs):
    for s in range(3):
        p = pe * 3 + s
        if cs[p, C_PRESENT] and cs[p, C_LAST_ISSUED]:
            return True
    return False


@njit(**_INLINE)
def pe_progressed(pe, cs, cflags, pes):
    if pes[pe, P_MOVED] or pes[pe, P_DIS_MOVED] or pes[pe, P_COL_MOVED]:
        return True
    for s in range(3):
        p = pe * 3 + s
        if cs[p, C_LAST_ISSUED]:
            return True
        if not cs[p, C_HALTED] and cflags[cs[p, C_CAUSE]] == 0:
            return True
    return False


@njit(**_OPTS)  # rare: a call of its own spares compile time
def unsent(npes, cm, cin, route, rem, fq, fbw):
    """machine.Machine.unsent_messages, as a test: some processor is in the middle of sending
    a message on the ring (its CMU still waits for words of it, or its send FIFO ends in a
    message cut short)."""
    cap = fbw.shape[1]
    for m in range(npes * 3):
        need = rem[m, 0] if route[m, 0] != -2 else 0
        f = cin[m, 0]
        h = fq[f, Q_HEAD]
        for k in range(fq[f, Q_CNT]):
            if need == 0:
                need = fbw[f, (h + k) % cap] & 255
            else:
                need -= 1
        if need:
            return True
    return False


@njit(**_OPTS)
def run_loop(g, until, cs, regs, ready, prod, wbn, wbr, wbw, busy, occ, unitn, stpc, bpc, ops,
             opk, opf, bun, recvq, sendq, fq, fbt, fbw, mem, seg, ctags, rg, rmap, rdense,
             rcnt, pcnt, cm, cin, cout, route, rem, lown, linkw, pes, dis, dcur, doff, dup, dasg,
             moff, mwords, col, cpart, cplen, frame, ids, cflags, pw, lrec, finfo):
    """Run cycles from g[G_CYCLE] until the run ends or the cycle `until` is reached; returns
    the status code (S_*). The cycle counter in g is advanced like machine.cycle. Every
    processor is awake on return (its cycles charged), so the state reads as the reference's."""
    code = run_cycles(g, until, cs, regs, ready, prod, wbn, wbr, wbw, busy, occ, unitn, stpc,
                      bpc, ops, opk, opf, bun, recvq, sendq, fq, fbt, fbw, mem, seg, ctags, rg,
                      rmap, rdense, rcnt, pcnt, cm, cin, cout, route, rem, lown, linkw, pes, dis,
                      dcur, doff, dup, dasg, moff, mwords, col, cpart, cplen, frame, ids, cflags,
                      pw, lrec, finfo)
    wake_all(cs, stpc, g[G_NPES] * 3, g[G_CYCLE] - 1, g[G_NPES] * 3)
    flush_stalls(cs, stpc, g[G_NPES] * 3)
    return code


@njit(**_OPTS)
def run_cycles(g, until, cs, regs, ready, prod, wbn, wbr, wbw, busy, occ, unitn, stpc, bpc, ops,
               opk, opf, bun, recvq, sendq, fq, fbt, fbw, mem, seg, ctags, rg, rmap, rdense,
               rcnt, pcnt, cm, cin, cout, route, rem, lown, linkw, pes, dis, dcur, doff, dup, dasg,
               moff, mwords, col, cpart, cplen, frame, ids, cflags, pw, lrec, finfo):
    """run_loop's cycles (faults wake the sleeping processors themselves: not all of them were
    stepped in the faulting cycle)."""
    W = g[G_W]
    A = (cs, regs, ready, prod, wbn, wbr, wbw, busy, occ, unitn, stpc, bpc, ops, opk, opf, bun,
         recvq, sendq, fq, fbt, fbw, mem, seg, ctags, rg, rmap, rdense, rcnt, pcnt, pw, lrec)
    npes = g[G_NPES]
    pooled = g[G_POOLED]
    limit = g[G_DEADLOCK_CYCLES]
    nmsgs = dis[D_NMSGS]
    ahead = g[G_AHEAD]
    # the CMUs' round robin starts at input c mod n: counted along, not divided, when every CMU
    # has the same n
    rn = cm[0, M_N]
    uniform = True
    for m in range(npes * 3):
        if cm[m, M_N] != rn:
            uniform = False
    rr = 0
    rr_c = -2
    while g[G_CYCLE] < until:
        c = g[G_CYCLE]
        if c == rr_c + 1:
            rr = rr + 1 if rr + 1 < rn else 0
        else:
            rr = c % rn
        rr_c = c
        dis_changed = False
        # whether some processor issued in cycle c itself: one that then ran ahead reads as not
        # issued (its C_LAST_ISSUED speaks for the last cycle it stepped), yet its bundle in
        # cycle c may have popped a FIFO — a slot free from c + 1 for a CMU or a sender to
        # take — so the cycle is not quiet (skip_quiet)
        issued_in_c = False
        # DIS (machine.Dis.step)
        if dis[D_DYNAMIC] and dis[D_NEXT] < nmsgs:
            best = -1
            best_load = 0
            for i in range(npes):
                if dcur[i] < 0 and fq[pes[i, P_HOST], Q_CNT] == 0:
                    ld = ring_words(i, pw)
                    if best < 0 or ld < best_load:
                        best = i
                        best_load = ld
            if best >= 0:
                dis_changed = True
                dcur[best] = dis[D_NEXT]
                doff[best] = 0
                dasg[best] += 1
                dis[D_NEXT] += 1
        for i in range(npes):
            pes[i, P_DIS_MOVED] = 0
            if dcur[i] < 0:
                if dis[D_DYNAMIC] or dup[i] >= nmsgs:
                    continue
                dis_changed = True
                dcur[i] = dup[i]
                doff[i] = 0
                dasg[i] += 1
                dup[i] += npes
            hq = pes[i, P_HOST]
            if q_free(fq, hq, c) > 0:
                dis_changed = True
                msg = dcur[i]
                q_push(fq, fbt, fbw, pw, hq, c, mwords[moff[msg] + doff[i]])
                doff[i] += 1
                if doff[i] == moff[msg + 1] - moff[msg]:
                    dcur[i] = -1
                dis[D_WORDS_SENT] += 1
                pes[i, P_DIS_MOVED] = 1
        # PEs (pe.PE.step): processors, then CMUs
        for pe in range(npes):
            for s in range(3):
                p = pe * 3 + s
                if cs[p, C_PRESENT]:
                    if cs[p, C_AHEAD]:
                        if c < cs[p, C_SLEEP]:
                            continue
                        ahead_end(cs, p)
                    elif cs[p, C_SLEEP]:
                        if c < pw[pe, W_WAKE + s]:
                            continue
                        wake(cs, stpc, p, c)
                    # step it in cycle c and, if it may, run it ahead (state.py C_AHEAD):
                    # on through the cycles after c, before the rest of the machine, for as
                    # long as its next bundle is private (B_PRIVATE) or it is held (a hold in
                    # one step: hold_through). Those cycles change only its own registers,
                    # memories and counters and read nothing another part of the machine
                    # writes, so taking them early gives the same outcome. It stops short of
                    # `until` and of the first bundle that would touch a FIFO or halt, and then
                    # sleeps until the cycle it reached. A fault ahead of cycle c is reported
                    # as one, and the engine runs the chunk again without running ahead (its
                    # report must show every processor in the fault's cycle). The text holds
                    # one core_step: each inlined copy costs seconds of compile time.
                    t = c
                    while True:
                        if core_step(t, p, A, W, finfo):
                            wake_all(cs, stpc, npes * 3, c, p)
                            g[G_CYCLE] = c + 1
                            return S_FAULT
                        if t == c and cs[p, C_LAST_ISSUED]:
                            issued_in_c = True
                        t += 1
                        if not ahead or cs[p, C_SLEEP] or cs[p, C_HALTED]:
                            break
                        while t < until and (t < cs[p, C_HOLD_UNTIL] or t < cs[p, C_WAKE]):
                            t = hold_through(t, p, until, A, W)
                        if t >= until:
                            break
                        pc = cs[p, C_PC]
                        if pc < 0 or pc >= cs[p, C_NB] or not bun[p, pc, B_PRIVATE]:
                            break
                    if t > c + 1:
                        cs[p, C_AHEAD] = 1
                        cs[p, C_AHEAD_ISSUED] = cs[p, C_LAST_ISSUED]
                        cs[p, C_AHEAD_CAUSE] = cs[p, C_CAUSE]
                        cs[p, C_LAST_ISSUED] = 0
                        cs[p, C_CAUSE] = CAUSE_BRANCH  # its own stall: neither idle nor stuck
                        cs[p, C_SLEEP] = t
            moved = 0
            start = rr if uniform else c % cm[pe * 3, M_N]  # a PE's CMUs: as many inputs
            for s in range(3):
                r = cmu_step(c, start, pe * 3 + s, cm, cin, cout, route, rem, lown, linkw, fq,
                             fbt, fbw, pw, pooled, finfo)
                if r < 0:
                    finfo[3] = pe
                    wake_all(cs, stpc, npes * 3, c, pe * 3 + 3)
                    g[G_CYCLE] = c + 1
                    return S_FAULT
                if r:
                    moved = 1
            pes[pe, P_MOVED] = moved
        # COL (machine.Col.step)
        for i in range(npes):
            pes[i, P_COL_MOVED] = 0
            cq = pes[i, P_COL]
            if not q_ready(fq, fbt, cq, c):
                continue
            w = q_pop(fq, fbw, pw, cq, c)
            pes[i, P_COL_MOVED] = 1
            col[L_WORDS] += 1
            cpart[i, cplen[i]] = w
            cplen[i] += 1
            hw = cpart[i, 0] & 0xFFFFFFFF
            length = hw & 255
            dest = (hw >> 8) & 3
            if dest != 3 or (length != 2 and length != 4):
                finfo[0] = F_COL_HEADER
                finfo[1] = i
                finfo[2] = cpart[i, 0]
                wake_all(cs, stpc, npes * 3, c, npes * 3)
                g[G_CYCLE] = c + 1
                return S_FAULT
            if cplen[i] == length + 1:
                pixel = as_i(cpart[i, 1])
                width = col[L_WIDTH]
                if pixel < 0 or pixel >= width * col[L_HEIGHT]:
                    finfo[0] = F_COL_PIXEL
                    finfo[1] = i
                    finfo[2] = pixel
                    wake_all(cs, stpc, npes * 3, c, npes * 3)
                    g[G_CYCLE] = c + 1
                    return S_FAULT
                y = pixel // width
                x = pixel - y * width
                if length == 2:
                    ids[y, x] = as_i(cpart[i, 2])
                else:
                    for k in range(3):
                        frame[y, x, k] += np.float64(as_f(F, cpart[i, 2 + k]))
                col[L_MESSAGES] += 1
                cplen[i] = 0
        g[G_CYCLE] = c + 1
        # end of the run (machine.Machine._check_end)
        all_halted = True
        for p in range(npes * 3):
            if cs[p, C_PRESENT] and not cs[p, C_HALTED]:
                all_halted = False
                break
        col_empty = True
        for i in range(npes):
            if cplen[i] or fq[pes[i, P_COL], Q_CNT]:
                col_empty = False
                break
        if all_halted and col_empty:
            if unsent(npes, cm, cin, route, rem, fq, fbw):
                return S_DEADLOCK_MSG
            return S_HALTED
        any_issued = False
        for i in range(npes):
            if pe_issued(i, cs):
                any_issued = True
                break
        if not any_issued:
            all_idle = True
            for i in range(npes):
                if not pe_idle(i, cs, cflags, pw):
                    all_idle = False
                    break
            exhausted = True
            for i in range(npes):
                if dcur[i] >= 0:
                    exhausted = False
            if exhausted:
                if dis[D_DYNAMIC]:
                    exhausted = dis[D_NEXT] >= nmsgs
                else:
                    for i in range(npes):
                        if dup[i] < nmsgs:
                            exhausted = False
            if all_idle and exhausted:
                if col_empty:
                    if unsent(npes, cm, cin, route, rem, fq, fbw):
                        return S_DEADLOCK_MSG
                    return S_FINISHED
                anycol = False
                for i in range(npes):
                    if fq[pes[i, P_COL], Q_CNT]:
                        anycol = True
                if not anycol:
                    return S_DEADLOCK_COL
        for i in range(npes):
            if (pe_issued(i, cs) or pe_progressed(i, cs, cflags, pes)
                    or pe_idle(i, cs, cflags, pw)):
                pes[i, P_NO_PROGRESS] = 0
                continue
            pes[i, P_NO_PROGRESS] += 1
            if pes[i, P_NO_PROGRESS] >= limit:
                finfo[1] = i
                return S_DEADLOCK_PE
        # a stop point (debugger fast-forward): this processor's next bundle is at that PC
        sp = g[G_STOP_P]
        if sp >= 0 and cs[sp, C_PC] == g[G_STOP_PC] and not cs[sp, C_HALTED]:
            return S_STOPPED
        if not any_issued and not dis_changed and not issued_in_c:
            skip_quiet(c, until, limit, npes, W, cs, regs, wbn, wbr, wbw, stpc, pes, pw, cflags,
                       g)
    return S_RUNNING


@njit(**_INLINE)
def skip_quiet(c, until, limit, npes, W, cs, regs, wbn, wbr, wbw, stpc, pes, pw, cflags, g):
    """After a quiet cycle c — no bundle issued, no word moved, DIS unchanged, every word in
    every FIFO already visible — nothing can change until some processor's stall runs out (a
    hold, an operand, a destination, a busy unit: each knows its cycle) or the deadlock
    detector's count reaches its limit. Charge the cycles until then at once, each to the
    cause the cycle-by-cycle rule would charge (the same as in cycle c), and apply the results
    that fall due meanwhile. A processor waiting on a FIFO with results still in flight, or
    one stalled on write ports, ends the skip (its checks depend on the cycle)."""
    for i in range(npes):
        if pes[i, P_MOVED] or pes[i, P_COL_MOVED] or pw[i, W_LASTVIS] > c:
            return
    c1 = c + 1
    T = until
    for p in range(npes * 3):
        if not cs[p, C_PRESENT] or cs[p, C_HALTED]:
            continue
        if cs[p, C_AHEAD]:  # ahead of the machine: charged up to the cycle it reached
            w = cs[p, C_SLEEP]
        elif cs[p, C_SLEEP]:  # asleep: charged when it wakes
            w = pw[p // 3, W_WAKE + p % 3]
        elif c1 < cs[p, C_HOLD_UNTIL]:
            w = cs[p, C_HOLD_MEM_UNTIL] if c1 < cs[p, C_HOLD_MEM_UNTIL] else cs[p, C_HOLD_UNTIL]
        elif c1 < cs[p, C_WAKE]:
            w = cs[p, C_WAKE]
        elif cflags[cs[p, C_CAUSE]] != 0 and cs[p, C_NPEND] == 0:
            continue
        else:
            return
        if w < T:
            T = w
    for i in range(npes):
        if not pe_progressed(i, cs, cflags, pes) and not pe_idle(i, cs, cflags, pw):
            b = c1 + limit - 1 - pes[i, P_NO_PROGRESS]
            if b < T:
                T = b
    if T <= c1:
        return
    k = T - c1
    for p in range(npes * 3):
        if not cs[p, C_PRESENT] or cs[p, C_HALTED] or cs[p, C_SLEEP]:
            continue
        if c1 < cs[p, C_HOLD_UNTIL]:
            cause = cs[p, C_HOLD_CAUSE] if c1 < cs[p, C_HOLD_MEM_UNTIL] else CAUSE_BRANCH
            pcx = cs[p, C_HOLD_PC]
        elif c1 < cs[p, C_WAKE]:
            cause = cs[p, C_WAKE_CAUSE]
            pcx = cs[p, C_PC]
        else:
            cause = cs[p, C_CAUSE]
            pcx = cs[p, C_LAST_PC]
        cs[p, C_CYCLES] += k
        stall(cs, stpc, p, cause, pcx, k)
    last = T - 1 if T - 1 < c + W - 1 else c + W - 1
    for p in range(npes * 3):
        if cs[p, C_NPEND] and not cs[p, C_AHEAD]:
            for t in range(c1, last + 1):
                write_due(cs, regs, wbn, wbr, wbw, p, t & (W - 1))
    for i in range(npes):
        if not pe_progressed(i, cs, cflags, pes) and not pe_idle(i, cs, cflags, pw):
            pes[i, P_NO_PROGRESS] += k
    g[G_CYCLE] = T
