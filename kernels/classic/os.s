# kernels/classic/os.s — the 1992-style OS (`--kernels classic`): the object-search stage as first
# written, one leaf per VISIT and every step's three crossings computed afresh; kernels/os.s is
# today's (the incremental step, two leaves per VISIT). Two-level uniform-grid traversal (3-D DDA).
#
# Contract: docs/kernels.md (messages, slots), docs/golden.md "Traversal (OS)" (every float
# operation, in order), docs/databases.md (voxel_data). Assembled per scene with the host's
# symbols (host/databases.py) plus -D SLOTS=n (rays in flight, default 8) and -D SERIAL_TREES=1
# (the serial mode, see below; default 0).
#
# Per ray, exactly as host/traversal.py does it for a whole wavefront:
#   setup   inv = 1/d, which axes step, the grid-entry slab, t_enter, the start voxel
#   step    one leaf per step: the three boundary crossings t_x, t_y, t_z of the current voxel
#           (independent per axis: the three chains share the bundles), its voxel word, the
#           exit axis, the step along that axis. A non-empty leaf goes to IC as VISIT_FIRST /
#           VISIT; the ray then sleeps in its slot until IC answers NEXT (go on from the next
#           leaf) or DONE (free the slot), and OS works on other rays meanwhile.
#   end     a surface ray that leaves (or misses) the grid -> MISS (pixel, w) to SC; a shadow
#           ray that leaves the grid or whose leaf reaches t_max -> COLOR (pixel, c) to SC.
#
# Exactness. Every float value that decides anything is computed with the golden model's
# single IEEE operations in its order: boundary = lo + float(i)*cell, t = (boundary - o)*inv,
# p = o + t*d, index = floor((p - lo)*inv_cell). numpy's minimum/maximum return the second
# operand on ties (min(+0.0, -0.0) = -0.0), so where a min/max is *kept* (t_enter, a leaf's
# t_exit) it is a compare and a select, `a < b ? a : b`, never fmin/fmax; where only the value
# is compared, fmin is fine.
#
# Three exact tricks keep the step short:
#   * a non-stepping axis gets o = -inf and inv = +inf in the loop: its crossing
#     (b - (-inf)) * inf is +inf, the golden "+inf where the axis does not step", with no select;
#   * the loop keeps kb = index + up (up = 1 on an axis stepping up): the boundary a voxel is
#     left through is then always lo + float(kb)*cell (golden: index + 1 up, index down), and
#     "the index is still in 0..res-1 after a step" is the one unsigned compare kb <u res + up;
#   * the voxel word's address is kept and moved by +-1, +-nx, +-nx*ny per step.
#
# The OS VLIW issues 2 integer + 2 FP operations a cycle but has only 2 register write ports:
# at most two operations that write a register per bundle, and at most two results completing
# in a cycle. Stores, sends and branches write no register; the step is scheduled around that.
#
# Layout of the program:
#   start            constants, free-slot stack
#   main             the loop: ring first (ring_msg: on_next / on_done / on_ray -> enqueue),
#                    then a deferred NEXT (from_defer), then a queued ray (from_queue), then a
#                    host ray (from_host); else `wait`
#   setup            a new ray: 1/d, stepping classes, grid entry, start voxel (setup_nonstep:
#                    the golden inside test for axes that do not step); ends in its first step
#   step             one leaf: crossings, voxel word, exit axis (step_x / step_y / step_z),
#                    `jr cont` -> step again (empty voxel) or nonempty
#   leaf_end         the previous leaf reached t_max (shadow ray done) or ended its sub-grid
#   level_out        the index left the level: leave_sub (back to the top level) or ray_end
#   nonempty         VISIT / VISIT_FIRST (then back to main), or sub_enter (a divided voxel)
#   on_next          NEXT from IC: reload the ray's state from its slot, on with `step`
#   ray_end          MISS / COLOR to SC, free the slot
#   drain            a message does not fit the send FIFO: read the ring meanwhile (OS never
#                    blocks in `send`, so the ring cannot deadlock; docs/kernels.md)
#
# Serial mode (-D SERIAL_TREES=1, used with SLOTS=1; docs/kernels.md "Serial mode"): one pixel's
# ray tree at a time. `alive` counts the tree's rays not yet finished: a host ray sets it to 1,
# each RAY from SC adds 1; a ray ending at OS (MISS / COLOR), an occluded shadow ray's DONE and
# SC's SHADED (a hit shaded, every ray it spawned already sent) take 1 off; a surface ray's DONE
# (a hit) changes nothing: it ends with its SHADED. A host ray is taken only when alive = 0. A
# RAY from SC also waits in the queue while older rays wait there (strict FIFO: with one slot
# IC then sees each tree in level order, whatever the timing). Without SERIAL_TREES none of this
# is assembled.
#
# Cost (emulator, IC answering at once; SLOTS=8, balls:2): ~88 cycles per ray setup, 16-18
# per step (the three crossing chains are ~14 cycles deep), ~16 per visit sent, ~21 to resume
# after NEXT, ~42 to enter a sub-grid, 11 to leave it.

.proc os
.include "protocol.inc"

.ifndef SLOTS
.equ SLOTS, 8                   # rays in flight (-D SLOTS=n)
.endif
.if SLOTS < 1
.error "SLOTS must be at least 1"
.endif
.ifndef SERIAL_TREES
.equ SERIAL_TREES, 0            # one ray tree at a time (-D SERIAL_TREES=1)
.endif

# Secondary rays (shadow, reflection, refraction) come back from SC as RAY messages on the
# ring; a scene without lights and mirrors has none (no ring RAYs, no overflow queue).
.equ SECONDARY, NLIGHTS > 0 || HAS_REFLECTION || HAS_REFRACTION

# ---------------------------------------------------------------------------------------------
# OS local memory
#   0 .. VOXEL_BASE           this program's .data: free-slot stack, top-level clamp bounds
#   VOXEL_BASE ..             voxel data (written by the host)
#   OS_FREE_BASE ..           slot table: SLOTS records of SLOT_WORDS words
#   QUEUE_BASE .. QUEUE_END   overflow queue: rays from SC that found every slot busy (a ring
#                             buffer of QUEUE_ENTRY-word entries filling the rest of memory)
#   NDEFER, DEFERRED ..       the last SLOTS + 1 words: the deferred NEXTs (see drain): their
#                             count, then the slots (one NEXT per slot at most)

.equ SLOT_SHIFT, 6
.equ SLOT_WORDS, 1 << SLOT_SHIFT
.equ SLOT_TABLE, OS_FREE_BASE
.equ QUEUE_BASE, SLOT_TABLE + SLOTS * SLOT_WORDS
.equ QUEUE_ENTRY, 16
.equ NDEFER, OS_LOCAL_WORDS - SLOTS - 1
.equ DEFERRED, NDEFER + 1
.equ QUEUE_CAP, (NDEFER - QUEUE_BASE) / QUEUE_ENTRY
.equ QUEUE_END, QUEUE_BASE + QUEUE_CAP * QUEUE_ENTRY
.if QUEUE_CAP < 1
.error "OS local memory is full: no room for the slot table and the ray queue"
.endif

# A slot (word offsets from its base address `sp`):
.equ S_RAY, 0                   # the 13-word ray record (RAY_* offsets)
.equ S_OO, 13                   # 3: o; -inf on an axis that does not step
.equ S_II, 16                   # 3: 1/d; +inf on an axis that does not step
.equ S_ST, 19                   # 3: step -1 / 0 / +1 (int)
.equ S_UP, 22                   # 3: 1 where the axis steps up (int)
.equ S_STMAX, 25                # shadow ray: t_max; surface ray: NaN (so every compare is false)
.equ S_FIRST, 26                # 1 until the first visit has gone out (VISIT_FIRST, then VISIT)
.equ S_INSUB, 27                # 1 while the ray is inside a sub-grid
.equ S_KB, 28                   # 3: \ saved when a visit goes out: kb and voxel-word address
.equ S_ADDR, 31                 #    | of the next voxel of the current level, the visited
.equ S_TCUR, 32                 #   /  voxel's exact exit t
.equ S_TOP_R, 33                # 3: top level: res + up
.equ S_TOP_DS, 36               # 3: top level: address steps st_x, st_y*nx, st_z*nx*ny
.equ S_TOP_KB, 39               # 3: \ the top level while the ray is in a sub-grid (already
.equ S_TOP_ADDR, 42             #   /  stepped past the divided voxel)
.equ S_SUB_HDR, 43              # the sub-grid's header address (its lo and cell)
.equ S_SUB_R, 44                # 3: sub level: res + up
.equ S_SUB_DS, 47               # 3: sub level: address steps st_x, st_y*mx, st_z*mx*my
.equ S_SUB_EXIT, 50             # the divided top voxel's exact T_exit
.equ S_SUB_LIM, 51              # t_max < T_exit ? t_max : T_exit (see `lim`)
.if S_SUB_LIM >= SLOT_WORDS
.error "the slot record does not fit SLOT_WORDS"
.endif

.data
free_stack: .space SLOTS        # indices of the free slots: nfree of them
top_rm:     .space 3            # float(res_a - 1): the top level's start-index clamp bounds
.text

# ---------------------------------------------------------------------------------------------
# Registers

# kept for the whole run
.reg finf     = r1              # +inf
.reg fninf    = r2              # -inf
.reg fnan     = r3              # NaN
.reg nfree    = r4              # number of free slots (top of free_stack)
.reg qcount   = r5              # rays waiting in the overflow queue
.reg qhead    = r6              # next queue entry to take
.reg qtail    = r7              # next queue entry to fill
.reg stepaddr = r8              # address of `step`: the continuation after an empty leaf
.reg neaddr   = r9              # address of `nonempty`: the continuation after a non-empty one
# serial mode: rays of the current tree not finished (os.s makes no call: the link register is free)
.if SERIAL_TREES
.reg alive    = r63
.endif
# the ray being traversed (from its slot)
.reg sp       = r10             # slot base address
.reg slot     = r11             # slot index (what IC sees)
.reg oox      = r12             # o; -inf on a non-stepping axis
.reg ooy      = r13
.reg ooz      = r14
.reg iix      = r15             # 1/d; +inf on a non-stepping axis
.reg iiy      = r16
.reg iiz      = r17
.reg stx      = r18             # step -1 / 0 / +1
.reg sty      = r19
.reg stz      = r20
.reg stmax    = r21             # t_max (shadow ray) or NaN (surface ray)
.reg insub    = r22             # 1 while in a sub-grid
# the level being traversed (the top grid, or one sub-grid) and the ray's place in it
.reg llox     = r23             # lo
.reg lloy     = r24
.reg lloz     = r25
.reg lcx      = r26             # cell
.reg lcy      = r27
.reg lcz      = r28
.reg lRx      = r29             # res + up: kb is inside the level iff kb <u lR
.reg lRy      = r30
.reg lRz      = r31
.reg dsx      = r32             # voxel-word address change of a step along each axis
.reg dsy      = r33
.reg dsz      = r34
.reg lexit    = r35             # in a sub-grid: the divided top voxel's T_exit; top: +inf
.reg lim      = r36             # t_max < lexit ? t_max : lexit (see leaf_end)
.reg kbx      = r37             # voxel index + up
.reg kby      = r38
.reg kbz      = r39
.reg addr     = r40             # address of the current voxel's word
.reg tcur     = r41             # a visited voxel's exact exit t
.reg tprev    = r42             # the current voxel's t_enter (the previous voxel's exit t)
.reg cont     = r43             # where a step goes after its dispatch: step or nonempty
# step temporaries
.reg lend     = r44             # the previous leaf's exit t reached lim (see leaf_end)
.reg tx       = r46             # the current voxel's boundary crossings
.reg ty       = r47
.reg tz       = r48
.reg vw       = r49             # its voxel word
.reg nax      = r50             # the next voxel's word address if the step is along x
.reg nay      = r51             #   ... along y
.reg cxy      = r53             # the golden exit-axis rule: x if tx <= ty and tx <= tz,
.reg cxz      = r54             #   else y if ty <= tz, else z
.reg cyz      = r55
.reg lt1      = r56             # \ the exact exit t min(min(tx, ty), tz) with numpy's ties,
.reg m1       = r57             # /  finished as `lt1 ? m1 : tz` at the next step's start
# general temporaries (message handling)
.reg t0       = r58
.reg t1       = r59
.reg t2       = r60
.reg t3       = r61
.reg t4       = r62
# the drain (a message waits for room in the send FIFO): step temporaries, dead on both send paths
.reg d0       = r46             # (tx, ty, tz)
.reg d1       = r47
.reg d2       = r48
.reg dneed    = r53             # words the message needs (cxy)
.reg dret     = r54             # where it is sent from (cxz)
# a ray on its way into a slot (only while it starts)
.reg one      = r49             # 1.0 for the setup's divisions
.reg qend     = r45             # (from_queue: the queue's end address)
.reg rpix     = r50             # the 13-word record

.reg rinfo    = r51
.reg rox      = r52
.reg roy      = r53
.reg roz      = r54
.reg rdx      = r55
.reg rdy      = r56
.reg rdz      = r57
.reg rtmin    = r58
.reg rtmax    = r59
.reg rwr      = r60
.reg rwg      = r61
.reg rwb      = r62

# ---------------------------------------------------------------------------------------------
# Start-up: constants, the free-slot stack, the top level's float clamp bounds

start:
    { lf finf, inf ; lf fninf, -inf }
    { lf fnan, nan ; li nfree, SLOTS }
    { li stepaddr, step ; li neaddr, nonempty }
    { li qcount, 0 ; li qhead, QUEUE_BASE }
    { li qtail, QUEUE_BASE ; li t0, 0 }
.if SERIAL_TREES
    li alive, 0
.endif
    li t1, SLOTS
init_free:                              # free_stack[i] = i
    { st t0, [t0 + free_stack] ; addi t0, t0, 1 }
    blt t0, t1, init_free
    { ld t0, [VOXEL_BASE + VD_RES] ; ld t1, [VOXEL_BASE + (VD_RES + 1)] }
    { ld t2, [VOXEL_BASE + (VD_RES + 2)] ; addi t0, t0, -1 }
    { addi t1, t1, -1 ; addi t2, t2, -1 }
    { itof t0, t0 ; itof t1, t1 }
    { itof t2, t2 }
    { st t0, [top_rm] ; st t1, [top_rm + 1] }
    { st t2, [top_rm + 2] ; st r0, [NDEFER] }

# ---------------------------------------------------------------------------------------------
# The main loop: the ring first (a ring message is never refused), then NEXTs the drain put
# aside, then queued rays, then a host ray if a slot is free; nothing to do: sleep in `wait`.
# With every slot busy (and no NEXT put aside) only the ring can help, so sleep in `recv` on the
# ring (a waiting host ray must not keep OS spinning).

# A ring message's header and first payload word (into `word`), then the jump for NEXT and DONE:
# `n` = tag - TAG_NEXT, `d` = tag - TAG_DONE (the other tags fall through, `tag` still the tag
# unless `d` is the same register). `main` and the drain both take messages this way.
.macro RING_MSG tag, word, n, d, next, done
    recv \tag, ring                                 # header
    { srli \tag, \tag, HDR_TAG_SHIFT ; recv \word, ring }  # tag; first payload word
    { addi \n, \tag, -TAG_NEXT ; addi \d, \tag, -TAG_DONE }
    beqz \n, \next
    beqz \d, \done
.endm

main:
    { poll t0, ring ; ld t1, [NDEFER] }
    { bnez t0, ring_msg ; sltu t2, r0, nfree }     # t2 = a slot is free
    bge t1, t2, defer_or_ring   # NEXTs put aside while OS waited to send (drain), or no free slot
.if SECONDARY
    bnez qcount, from_queue
.endif
.if SERIAL_TREES
    bnez alive, ring_msg        # serial mode: the current tree is not finished
.endif
    poll t0, host
    bnez t0, from_host
    wait
    j main

defer_or_ring:
    bnez t1, from_defer
ring_msg:
    RING_MSG t0, t3, t1, t2, on_next, on_done
.if SERIAL_TREES
    addi t1, t0, -TAG_SHADED
    beqz t1, on_shaded
.endif
.if SECONDARY
    j on_ray
.else
    j main                                          # (nothing else reaches OS here)
.endif

# a deferred NEXT (t1 = ndefer > 0): resume the ray as if its NEXT had just arrived
from_defer:
    { ld t3, [t1 + (DEFERRED - 1)] ; addi t1, t1, -1 }
    { st t1, [NDEFER] ; j on_next }

# DONE (t3 = slot): the ray ended at IC (a hit, or an occluded shadow ray)
on_done:
    { st t3, [nfree + free_stack] ; addi nfree, nfree, 1 }
.if SERIAL_TREES
    slli t1, t3, SLOT_SHIFT                         # serial mode: an occluded shadow ray ends
    ld t1, [t1 + (SLOT_TABLE + RAY_INFO)]           #   here; a surface ray's hit ends with
    andi t1, t1, 3                                  #   its SHADED
    addi t1, t1, -KIND_SHADOW
    bnez t1, main
    { addi alive, alive, -1 ; j main }

# SHADED (serial mode; t3 = pixel): SC has shaded a hit and sent every ray it spawned
on_shaded:
    { addi alive, alive, -1 ; j main }
.else
    j main
.endif

# The middle of a RAY message, words 4..11 (o.z, d, t_min, t_max, w.r, w.g), from `port` into the
# ray registers, one a bundle (a new ray from SC on the ring or from the host).
.macro RECV_RAY port
    recv roz, \port
    recv rdx, \port
    recv rdy, \port
    recv rdz, \port
    recv rtmin, \port
    recv rtmax, \port
    recv rwr, \port
    recv rwg, \port
.endm

# A RAY message from SC into the overflow queue (on_ray finds no free slot; the drain takes one
# off the ring): its pixel word, received already, is in `pix`; the other 12 words come straight
# from the ring, `a` and `b` taking turns so a word is stored while the next arrives. Then the
# tail wraps and OS goes on at `next`. A full queue stops the run (queue_overflow).
.macro ENQUEUE pix, a, b, next
    li \a, QUEUE_CAP
    beq qcount, \a, queue_overflow
    { st \pix, [qtail + RAY_PIXEL] ; recv \a, ring }
.rept 5                                             # words 1..10
    { st \a, [qtail + (2 * \+ + 1)] ; recv \b, ring }
    { st \b, [qtail + (2 * \+ + 2)] ; recv \a, ring }
.endr
    { st \a, [qtail + 11] ; recv \b, ring }
    { st \b, [qtail + 12] ; addi qtail, qtail, QUEUE_ENTRY }
    { li \a, QUEUE_END ; addi qcount, qcount, 1 }
    bne qtail, \a, \next
    { li qtail, QUEUE_BASE ; j \next }
.endm

.if SECONDARY
# RAY from SC (t3 = its pixel word): start it in a free slot, or queue it
on_ray:
.if SERIAL_TREES
    { addi alive, alive, 1 ; bnez qcount, enqueue } # serial mode: strictly first come, first served
.endif
    beqz nfree, enqueue
    { addi nfree, nfree, -1 ; mov rpix, t3 }
    { ld slot, [nfree + free_stack] ; recv rinfo, ring }
    { slli sp, slot, SLOT_SHIFT ; recv rox, ring }
    { addi sp, sp, SLOT_TABLE ; recv roy, ring }
    RECV_RAY ring
    { recv rwb, ring ; lf one, 1.0 ; j setup }

enqueue:
    ENQUEUE t3, t0, t1, main

queue_overflow:                 # more rays wait than OS memory holds: stop the run with a
    ld t0, [r0 - 1]             # memory fault whose report names this label

# the oldest queued ray takes a free slot
from_queue:
    addi nfree, nfree, -1
    { ld slot, [nfree + free_stack] ; ld rpix, [qhead + 0] }
    { ld rinfo, [qhead + 1] ; ld rox, [qhead + 2] }
    { ld roy, [qhead + 3] ; ld roz, [qhead + 4] }
    { ld rdx, [qhead + 5] ; ld rdy, [qhead + 6] }
    { ld rdz, [qhead + 7] ; ld rtmin, [qhead + 8] }
    { ld rtmax, [qhead + 9] ; ld rwr, [qhead + 10] }
    { ld rwg, [qhead + 11] ; ld rwb, [qhead + 12] }
    { slli sp, slot, SLOT_SHIFT ; addi qhead, qhead, QUEUE_ENTRY }
    { addi sp, sp, SLOT_TABLE ; li qend, QUEUE_END }
    { addi qcount, qcount, -1 ; lf one, 1.0 ; bne qhead, qend, setup }
    { li qhead, QUEUE_BASE ; j setup }
.endif

# a primary ray from the host (DIS) takes a free slot
from_host:
.if SERIAL_TREES
    li alive, 1                                     # serial mode: a new tree
.endif
    { addi nfree, nfree, -1 ; recv t0, host }       # header (a RAY)
    { ld slot, [nfree + free_stack] ; recv rpix, host }
    { slli sp, slot, SLOT_SHIFT ; recv rinfo, host }
    { addi sp, sp, SLOT_TABLE ; recv rox, host }
    recv roy, host
    RECV_RAY host
    { recv rwb, host ; lf one, 1.0 }

# ---------------------------------------------------------------------------------------------
# Ray setup (golden "Traversal (OS)", per ray). In: the record in rpix..rwb, sp, slot, one = 1.0.
#   inv_a = 1/d_a; axis a steps iff inv_a is finite and non-zero (up if > 0, down if < 0);
#   slab: stepping up (t_lo, t_hi) = ((lo-o)*inv, (hi-o)*inv), stepping down swapped; not
#     stepping: (-inf, +inf) if lo <= o <= hi, else the ray misses (golden: (+inf, -inf));
#   t_enter = max(max(max(t_lo_x, t_lo_y), t_lo_z), t_min), t_far = min(min(t_hi_x, ..), ..);
#   the ray traverses iff t_enter <= t_far and (shadow rays) t_enter < t_max;
#   start index i_a = floor((o_a + t_enter*d_a - lo_a)*inv_cell_a) clamped to 0..res_a-1.
# On a stepping axis (lo-o)*inv and (hi-o)*inv differ unless both overflow to the same
# infinity (lo < hi), so "swapped when stepping down" is exactly fmin/fmax of the two.
# The level and state registers are free until the setup hands over to the step and serve as
# its temporaries (the names below), as do the record's registers once stored. The schedule
# follows the divider: it is not pipelined, so x and y divide first, and the slabs and x's
# class are worked out on the other FP unit while z divides.

.reg ivx  = r46                 # 1/d
.reg ivy  = r47
.reg ivz  = r48
.reg tent = r49                 # t_enter (r49 is `one` until the divisions are issued)
.reg stpx = r29                 # the axis steps (later inv_cell)
.reg stpy = r30
.reg stpz = r31
.reg ngx  = r32                 # 1/d < 0 (later float(res - 1))
.reg ngy  = r33
.reg ngz  = r34
.reg upx  = r37                 # up (kb = index + up is formed in place)
.reg upy  = r38
.reg upz  = r39
.reg tax  = r40                 # lo - o, then t_lo; later the start point
.reg tay  = r41
.reg taz  = r42
.reg tbx  = r43                 # hi - o, then t_hi
.reg tby  = r44
.reg tbz  = r45
.reg hx   = r50                 # the grid's far corner hi (rpix, rwr, rwg: free once stored)
.reg hy   = r60
.reg hz   = r61
.reg s0   = r62                 # (rwb)
.reg aa   = r59                 # |1/d| (rtmax)
.reg az   = r50                 # |1/d_z| (hx)
.reg all  = r35                 # every axis steps
.reg nx   = r51                 # res_x (rinfo, free once stored), res_y, res_z, nx*ny
.reg ny   = r44
.reg nz   = r45
.reg nxy  = r35
.reg icx  = r29                 # inv_cell (the stepping flags are done with)
.reg icy  = r30
.reg icz  = r31
.reg rmx  = r32                 # float(res - 1) (the down flags are done with)
.reg rmy  = r33
.reg rmz  = r34

setup:
    { fdiv ivx, one, rdx ; fdiv ivy, one, rdy ; st rdx, [sp + RAY_DX] ; st rdy, [sp + RAY_DY] }
    # while x and y divide: the record into the slot, the grid's corners, t_max (surface rays
    # get NaN: no compare with it is ever true)
    { ld llox, [VOXEL_BASE + VD_LO] ; st rpix, [sp + RAY_PIXEL] }
    { ld lloy, [VOXEL_BASE + (VD_LO + 1)] ; st rwb, [sp + RAY_WB] }
    { ld lloz, [VOXEL_BASE + (VD_LO + 2)] ; st rwr, [sp + RAY_WR] }
    { ld hx, [VOXEL_BASE + VD_HI] ; st rwg, [sp + RAY_WG] }
    { ld hy, [VOXEL_BASE + (VD_HI + 1)] ; andi s0, rinfo, 3 }
    { ld hz, [VOXEL_BASE + (VD_HI + 2)] ; addi s0, s0, -KIND_SHADOW }
    { sel stmax, s0, fnan, rtmax ; st rinfo, [sp + RAY_INFO] }
    { li s0, 1 ; st rox, [sp + RAY_OX] }
    { st roy, [sp + RAY_OY] ; st roz, [sp + RAY_OZ] }
    { st rdz, [sp + RAY_DZ] ; st rtmin, [sp + RAY_TMIN] }
    { st rtmax, [sp + RAY_TMAX] ; st stmax, [sp + S_STMAX] }
    { fdiv ivz, one, rdz ; fsub taz, lloz, roz }
    # while z divides, on the other FP unit: the slab distances lo - o, hi - o; x's class
    # (steps iff 0 < |1/d| < inf; up iff it steps and 1/d > 0) and slab ends
    { fsub tbz, hz, roz ; st s0, [sp + S_FIRST] }
    { fsub tax, llox, rox ; st r0, [sp + S_INSUB] }
    { fsub tbx, hx, rox ; li insub, 0 }
    { fsub tay, lloy, roy }
    { fsub tby, hy, roy }
    { fabs aa, ivx }
    { flt ngx, ivx, r0 }                                   # (r0 reads as +0.0)
    { flt stpx, r0, aa ; ld lcx, [VOXEL_BASE + VD_CELL] }
    { flt aa, aa, finf ; ld lcy, [VOXEL_BASE + (VD_CELL + 1)] }
    { fmul tax, tax, ivx ; and stpx, stpx, aa }
    { fmul tbx, tbx, ivx ; slt upx, ngx, stpx }
    # z's 1/d is ready: both units
    { fmul taz, taz, ivz ; fmul tbz, tbz, ivz }
    { fmul tay, tay, ivy ; fmul tby, tby, ivy }
    { fabs aa, ivy ; sel oox, stpx, rox, fninf }          # the loop's o and 1/d: -inf and +inf
    { flt ngy, ivy, r0 ; sel iix, stpx, ivx, finf }       #   on a non-stepping axis
    { ld lcz, [VOXEL_BASE + (VD_CELL + 2)] ; st oox, [sp + S_OO] }
    { ld nx, [VOXEL_BASE + VD_RES] ; st iix, [sp + S_II] }
    { fmin tax, tax, tbx ; fmax tbx, tax, tbx }           # x: (t_lo, t_hi)
    { flt stpy, r0, aa ; fabs az, ivz }
    { flt aa, aa, finf ; flt ngz, ivz, r0 }
    { fmin taz, taz, tbz ; fmax tbz, taz, tbz }           # z: (t_lo, t_hi)
    { fmin tay, tay, tby ; fmax tby, tay, tby }           # y: (t_lo, t_hi)
    { flt stpz, r0, az ; flt az, az, finf }
    { flt s0, tay, tax ; and stpy, stpy, aa }             # t_enter, first max(t_lo_x, t_lo_y)
    { sel tent, s0, tax, tay ; and stpz, stpz, az }
    { and all, stpx, stpy ; slt upy, ngy, stpy }
    { and all, all, stpz ; slt upz, ngz, stpz }
    { sel ooy, stpy, roy, fninf ; beqz all, setup_nonstep }
setup_tz:
    # t_enter = max(max(max(t_lo_x, t_lo_y), t_lo_z), t_min), numpy's max `a > b ? a : b`;
    # t_far = min(min(t_hi_x, t_hi_y), t_hi_z): only compared, fmin will do
    { flt s0, taz, tent ; fmin tbx, tbx, tby }
    { sel tent, s0, tent, taz ; fmin tbx, tbx, tbz }
    { flt s0, rtmin, tent ; sel iiy, stpy, ivy, finf }
    { sel tent, s0, tent, rtmin ; and stpx, stpx, ngx }   # (stepping down, for the steps)
    # start voxel: p = o + t_enter*d; i = floor(clamp((p - lo)*inv_cell, 0, res-1)). Clamping
    # before the floor gives the golden floor-then-clamp integer (the bounds are integers).
    { fmul tax, tent, rdx ; fmul tay, tent, rdy }
    { fmul taz, tent, rdz ; fle s0, tent, tbx }           # t_enter <= t_far
    { fle tbz, stmax, tent ; sel ooz, stpz, roz, fninf }  # t_enter >= t_max (surface: NaN: never)
    { slt s0, tbz, s0 ; sel iiz, stpz, ivz, finf }        # alive = the first and not the second
    { fadd tax, rox, tax ; and stpy, stpy, ngy ; beqz s0, ray_end }   # the ray misses the grid
    { fadd tay, roy, tay ; and stpz, stpz, ngz }
    { fadd taz, roz, taz ; fsub tax, tax, llox }
    { fsub tay, tay, lloy ; sub stx, upx, stpx }          # step = up - down: +1, -1 or 0
    { fsub taz, taz, lloz ; sub sty, upy, stpy }
    { sub stz, upz, stpz ; ld icx, [VOXEL_BASE + VD_INV_CELL] }
    { fmul tax, tax, icx ; ld icy, [VOXEL_BASE + (VD_INV_CELL + 1)] }
    { ld icz, [VOXEL_BASE + (VD_INV_CELL + 2)] ; st ooy, [sp + (S_OO + 1)] }
    { fmul tay, tay, icy ; ld rmx, [top_rm] }
    { fmul taz, taz, icz ; ld rmy, [top_rm + 1] }
    { ld rmz, [top_rm + 2] ; ld nxy, [VOXEL_BASE + VD_NXY] }
    { fmax tax, tax, r0 }                                 # (r0 = +0.0)
    { fmax tay, tay, r0 ; fmin tax, tax, rmx }
    { fmin tay, tay, rmy ; floor tax, tax }
    { fmax taz, taz, r0 ; floor tay, tay }
    { fmin taz, taz, rmz ; mul dsz, stz, nxy }
    { floor taz, taz ; ld ny, [VOXEL_BASE + (VD_RES + 1)] }
    # kb = index + up (in place of up); the voxel word's address TOP_VOXELS + ix + iy*nx +
    # iz*nx*ny; the top level's res + up and address steps (st_x, st_y*nx, st_z*nx*ny)
    { mul hx, tay, nx ; add lRx, nx, upx }
    { mul hy, taz, nxy ; mul dsy, sty, nx }               # (ds_y: rm_y is done with)
    { add lRy, ny, upy ; ld nz, [VOXEL_BASE + (VD_RES + 2)] }
    { add kbx, tax, upx ; st upx, [sp + S_UP] }
    { add kby, tay, upy ; st upy, [sp + (S_UP + 1)] }
    { add lRz, nz, upz ; st upz, [sp + (S_UP + 2)] }
    { add kbz, taz, upz ; addi addr, tax, TOP_VOXELS }
    # the first step's first bundles (as step_entry), with the setup's last integer work
    # (the voxel address, the slot's per-ray words) in their free integer slots
    { itof tx, kbx ; fmov dsx, stx ; st ooz, [sp + (S_OO + 2)] ; st iiy, [sp + (S_II + 1)] }
    { itof ty, kby ; add addr, addr, hx ; st iiz, [sp + (S_II + 2)] }
    { itof tz, kbz ; fmul tx, tx, lcx ; st stx, [sp + S_ST] }
    { fmul ty, ty, lcy ; add addr, addr, hy }
    { fmov tprev, tent ; fmov lexit, finf ; st sty, [sp + (S_ST + 1)] ; st stz, [sp + (S_ST + 2)] }
    { fmov lim, stmax ; st lRx, [sp + S_TOP_R] ; st lRy, [sp + (S_TOP_R + 1)] }
    { fmul tz, tz, lcz ; add nax, addr, dsx }
    { st lRz, [sp + (S_TOP_R + 2)] ; st dsx, [sp + S_TOP_DS] }
    { st dsy, [sp + (S_TOP_DS + 1)] ; st dsz, [sp + (S_TOP_DS + 2)] }
    j step_go

# Some axis does not step (a zero, subnormal or infinite direction component): golden
# (t_lo, t_hi) = (-inf, +inf) on it if lo <= o <= hi (hi reloaded: hx was reused), else the
# ray misses the grid.
setup_nonstep:
    { ld hx, [VOXEL_BASE + VD_HI] ; fle s0, llox, rox }
    { fle hx, rox, hx ; fle hy, roy, hy }
    { fle aa, lloy, roy ; fle hz, roz, hz }
    { and s0, s0, hx ; sel tax, stpx, tax, fninf }
    { and aa, aa, hy ; sel tbx, stpx, tbx, finf }
    { or s0, s0, stpx ; or aa, aa, stpy }
    { fle az, lloz, roz ; and s0, s0, aa }
    { and az, az, hz ; sel tay, stpy, tay, fninf }
    { or az, az, stpz ; sel tby, stpy, tby, finf }
    { and s0, s0, az ; sel taz, stpz, taz, fninf }
    { sel tbz, stpz, tbz, finf ; beqz s0, ray_end }
    flt s0, tay, tax
    { sel tent, s0, tax, tay ; j setup_tz }

# ---------------------------------------------------------------------------------------------
# The step: one leaf voxel of the current level.
#
# In: the ray's and the level's registers, kb and addr of the voxel to visit, and
#   `step_entry` (a level's first voxel: no previous leaf to check): tprev = its t_enter;
#   `step` (the loop; a ray resumed after NEXT): the previous voxel's exact exit t still as
#     the unfinished min `m1 < tz ? m1 : tz` (a resumed ray: m1 = tz = its saved exit t). The
#     first two bundles finish it into tprev; then the previous leaf is checked against lim.
# Out, at the dispatch: kb and addr moved to the neighbour across the exit face, m1 = min(tx,
# ty) and tz left for the next step, then `jr cont`: back to step (an empty voxel) or on to
# nonempty.
#
# Crossing per axis (golden): t_a = (lo_a + float(kb_a)*cell_a - o_a) * inv_a. The three
# chains (itof 2, fmul 3, fadd 2, fsub 2, fmul 3 cycles) are staggered by one cycle, so no
# more than two results land in any cycle (two write ports), and the checks of the previous
# leaf (t_max / sub-grid end) and of the index range ride along in the free slots.

step_entry:
    { itof tx, kbx }
    { itof ty, kby }
    { itof tz, kbz ; fmul tx, tx, lcx }
    { fmul ty, ty, lcy }
    { fmul tz, tz, lcz ; add nax, addr, dsx ; j step_go }
step:
    { itof tx, kbx ; flt lt1, m1, tz }                    # the previous voxel's exact exit t
    { itof ty, kby ; fsel tprev, lt1, m1, tz }            #   = this voxel's t_enter
    { itof tz, kbz ; fmul tx, tx, lcx }
    { fmul ty, ty, lcy ; fle lend, lim, tprev }           # did the previous leaf end something?
    { fmul tz, tz, lcz ; add nax, addr, dsx ; bnez lend, leaf_end }
step_go:
    { fadd tx, llox, tx ; add nay, addr, dsy }            # (next addresses along x and y)
    { fadd ty, lloy, ty ; bgeu kbx, lRx, level_out }      # index outside the level? (unsigned:
    { fadd tz, lloz, tz ; fsub tx, tx, oox }              #   kb = -1 is huge)
    { fsub ty, ty, ooy ; bgeu kby, lRy, level_out }
    { fsub tz, tz, ooz ; fmul tx, tx, iix }
    { fmul ty, ty, iiy ; bgeu kbz, lRz, level_out }
    { fmul tz, tz, iiz ; ld vw, [addr] }                  # the voxel word (inside: safe to read)
    sel cont, vw, neaddr, stepaddr                        # empty: loop on; else nonempty
    # the exit axis: x if tx <= ty and tx <= tz, else y if ty <= tz, else z. Alongside, the
    # exact exit t min(min(tx, ty), tz) = `m1 < tz ? m1 : tz`, m1 = `tx < ty ? tx : ty`
    # (finished at the next step's start, or in nonempty)
    { fle cxy, tx, ty }
    { beqz cxy, not_x ; fle cxz, tx, tz ; flt lt1, tx, ty }
    { beqz cxz, not_x ; fsel m1, lt1, tx, ty }
step_x:                                                   # (fmov: a raw move on an FP unit, as
    { add kbx, kbx, stx ; fmov addr, nax ; jr cont }      #  the two integer units are taken)
not_x:
    { fle cyz, ty, tz ; fsel m1, lt1, tx, ty }
    bnez cyz, step_y
step_z:
    { add kbz, kbz, stz ; add addr, addr, dsz }
    jr cont
step_y:
    { add kby, kby, sty ; fmov addr, nay ; jr cont }

# The previous leaf's exit t (tprev) reached lim = min(t_max, lexit). In the golden order:
#   the leaf's t_exit = min(tprev, lexit) (top level: lexit = +inf) >= t_max: a shadow ray is
#     done, unoccluded (surface rays: t_max is NaN, never);
#   tprev >= lexit: the sub-grid is finished (golden sub_end).
# One of the two holds whenever lend is set.
leaf_end:
    { flt t0, tprev, lexit }
    { fsel t1, t0, tprev, lexit }
    { fle t0, stmax, t1 ; fle t1, lexit, tprev }
    bnez t0, ray_end
    bnez t1, level_out
    j step_go                   # (not reached; the step's chains are still valid)

# The index left the level, or the sub-grid is finished.
level_out:
.if HAS_SUBGRIDS
    bnez insub, leave_sub
.endif
    j ray_end

# The top level's traversal state into the level registers: its lo corner and cell size (the
# voxel data's header) and the ray's res + up and voxel-address steps there (its slot).
.macro TOP_LEVEL
    { ld llox, [VOXEL_BASE + VD_LO] ; ld lloy, [VOXEL_BASE + (VD_LO + 1)] }
    { ld lloz, [VOXEL_BASE + (VD_LO + 2)] ; ld lcx, [VOXEL_BASE + VD_CELL] }
    { ld lcy, [VOXEL_BASE + (VD_CELL + 1)] ; ld lcz, [VOXEL_BASE + (VD_CELL + 2)] }
    { ld lRx, [sp + S_TOP_R] ; ld lRy, [sp + (S_TOP_R + 1)] }
    { ld lRz, [sp + (S_TOP_R + 2)] ; ld dsx, [sp + S_TOP_DS] }
    { ld dsy, [sp + (S_TOP_DS + 1)] ; ld dsz, [sp + (S_TOP_DS + 2)] }
.endm

.if HAS_SUBGRIDS
# Back to the top level, which was stepped past the divided voxel when the ray entered its
# sub-grid; its t_enter is the divided voxel's T_exit (lexit).
leave_sub:
    { ld kbx, [sp + S_TOP_KB] ; ld kby, [sp + (S_TOP_KB + 1)] }
    { ld kbz, [sp + (S_TOP_KB + 2)] ; ld addr, [sp + S_TOP_ADDR] }
    TOP_LEVEL
    { fmov tprev, lexit ; li insub, 0 ; st r0, [sp + S_INSUB] }
    { fmov lexit, finf ; fmov lim, stmax ; j step_entry }
.endif

# ---------------------------------------------------------------------------------------------
# A non-empty voxel, reached from the dispatch (kb and addr already point at the next voxel).
# vw > 0: a leaf -> VISIT; vw < 0 (top level only): a divided voxel -> its sub-grid.

# OS never blocks in `send` (docs/kernels.md "Deadlock freedom"): `room` first; a message that
# does not fit its send FIFO whole waits in `drain`, which keeps reading the ring meanwhile.

nonempty:
    { flt lt1, m1, tz ; ld t0, [sp + S_FIRST] ; st kbx, [sp + S_KB] }
.if HAS_SUBGRIDS
    { fsel tcur, lt1, m1, tz ; room t4, ring ; blt vw, r0, sub_enter }   # exact exit t
.else
    { fsel tcur, lt1, m1, tz ; room t4, ring }
.endif
    # the leaf's t_exit: top level tcur; in a sub-grid numpy's min(tn, T_exit), `tn < T ? tn : T`
    { flt lt1, tcur, lexit ; li t1, HDR_VISIT ; bnez t0, visit_first }
    { fsel m1, lt1, tcur, lexit ; slti t2, t4, 1 + LEN_VISIT }
    { bnez t2, visit_full ; st kby, [sp + (S_KB + 1)] }
visit_send:
    { send ring, t1 ; st kbz, [sp + (S_KB + 2)] }
    { send ring, slot ; st addr, [sp + S_ADDR] }
    { send ring, vw ; st tcur, [sp + S_TCUR] }
    { send ring, m1 ; j main }
visit_full:
    { li dneed, 1 + LEN_VISIT ; li dret, visit_send }
    j drain

# the first visit carries the ray record (t4 = room)
visit_first:
    { fsel m1, lt1, tcur, lexit ; slti t2, t4, 1 + LEN_VISIT_FIRST }
    { li t1, HDR_VISIT_FIRST ; bnez t2, first_full }
first_send:
    { send ring, t1 ; st kby, [sp + (S_KB + 1)] }
    { send ring, slot ; st kbz, [sp + (S_KB + 2)] }
    { send ring, vw ; st addr, [sp + S_ADDR] }
    { send ring, m1 ; st tcur, [sp + S_TCUR] }
    { ld t1, [sp + 0] ; st r0, [sp + S_FIRST] }
.rept 6                                             # the ray record, words 1..12: t1 and t2
    { ld t2, [sp + (2 * \+ + 1)] ; send ring, t1 }   #   take turns, one loaded while the
    { ld t1, [sp + (2 * \+ + 2)] ; send ring, t2 }   #   other is sent
.endr
    { send ring, t1 ; j main }
first_full:
    { li dneed, 1 + LEN_VISIT_FIRST ; li dret, first_send }
    j drain

.if HAS_SUBGRIDS
# Enter the sub-grid of a divided top voxel (vw = -(header address)). The top level is
# already stepped past it: save that. The divided voxel's T_exit is tcur, its t_enter tprev:
#   p = o + t_enter*d; sub index = floor(clamp((p - sub_lo)*sub_inv_cell, 0, sub_res - 1))
.reg hdr = r58                          # t0
.reg pxx = r46                          # tx, ty, tz: free after the dispatch
.reg pyy = r47
.reg pzz = r48
.reg smx = r50                          # sub_res mx, my, mz
.reg smy = r51
.reg smz = r52
.reg sux = r53                          # up
.reg suy = r54
.reg suz = r55
.reg fmx = r44                          # float(sub_res - 1): the clamp bounds
.reg fmy = r45
.reg fmz = r56
.reg mxy = r62                          # mx*my
sub_enter:
    { sub hdr, r0, vw ; ld pxx, [sp + RAY_DX] }
    { ld pyy, [sp + RAY_DY] ; ld pzz, [sp + RAY_DZ] }
    { fmul pxx, tprev, pxx ; ld smx, [hdr + SG_RES] ; st addr, [sp + S_TOP_ADDR] }
    { fmul pyy, tprev, pyy ; ld smy, [hdr + (SG_RES + 1)] ; st kbx, [sp + S_TOP_KB] }
    { fmul pzz, tprev, pzz ; ld smz, [hdr + (SG_RES + 2)] ; st kby, [sp + (S_TOP_KB + 1)] }
    { ld t1, [sp + RAY_OX] ; addi fmx, smx, -1 }
    { ld t2, [sp + RAY_OY] ; addi fmy, smy, -1 }
    { fadd pxx, t1, pxx ; ld t3, [sp + RAY_OZ] }
    { fadd pyy, t2, pyy ; itof fmx, fmx }
    { fadd pzz, t3, pzz ; ld llox, [hdr + SG_LO] }
    { itof fmy, fmy ; addi fmz, smz, -1 }
    { fsub pxx, pxx, llox ; ld lloy, [hdr + (SG_LO + 1)] ; st kbz, [sp + (S_TOP_KB + 2)] }
    { fsub pyy, pyy, lloy ; ld lloz, [hdr + (SG_LO + 2)] }
    { fsub pzz, pzz, lloz ; ld t1, [hdr + SG_INV_CELL] }
    { fmul pxx, pxx, t1 ; ld t2, [hdr + (SG_INV_CELL + 1)] }
    { fmul pyy, pyy, t2 ; ld t3, [hdr + (SG_INV_CELL + 2)] }
    { fmul pzz, pzz, t3 ; itof fmz, fmz }
    { ld sux, [sp + S_UP] ; ld suy, [sp + (S_UP + 1)] }
    { fmax pxx, pxx, r0 ; ld suz, [sp + (S_UP + 2)] }      # (r0 = +0.0)
    { fmax pyy, pyy, r0 ; fmin pxx, pxx, fmx }
    { fmax pzz, pzz, r0 ; fmin pyy, pyy, fmy }
    { fmin pzz, pzz, fmz ; floor pxx, pxx }
    { floor pyy, pyy ; fmov lexit, tcur }                 # the divided voxel's T_exit
    { floor pzz, pzz ; mul mxy, smx, smy }                # mx*my
    { mul t1, pyy, smx ; add kbx, pxx, sux }              # kb = index + up
    { mul t2, pzz, mxy ; add kby, pyy, suy }
    { add kbz, pzz, suz ; addi addr, hdr, SUB_HEADER_WORDS }
    { add addr, addr, pxx ; flt t3, stmax, lexit }
    # the sub-grid's first step (as step_entry), with the entry's remaining work alongside:
    # its word address, res + up, lim, the address steps st_x, st_y*mx, st_z*mx*my, and the
    # sub level's words in the slot
    { itof tx, kbx ; add lRx, smx, sux ; st hdr, [sp + S_SUB_HDR] }
    { itof ty, kby ; add lRy, smy, suy ; st lexit, [sp + S_SUB_EXIT] }
    { itof tz, kbz ; fsel lim, t3, stmax, lexit }
    { ld lcx, [hdr + SG_CELL] ; ld lcy, [hdr + (SG_CELL + 1)] }
    { fmul tx, tx, lcx ; ld lcz, [hdr + (SG_CELL + 2)] }
    { fmul ty, ty, lcy ; add addr, addr, t1 }
    { fmul tz, tz, lcz ; add addr, addr, t2 }
    { mul dsy, sty, smx ; mul dsz, stz, mxy }
    { add lRz, smz, suz ; fmov dsx, stx ; st lRx, [sp + S_SUB_R] }
    { add nax, addr, dsx ; st lRy, [sp + (S_SUB_R + 1)] }
    { li insub, 1 ; st lRz, [sp + (S_SUB_R + 2)] }
    { st dsx, [sp + S_SUB_DS] }
    { st dsy, [sp + (S_SUB_DS + 1)] ; st dsz, [sp + (S_SUB_DS + 2)] }
    { st lim, [sp + S_SUB_LIM] ; st insub, [sp + S_INSUB] }
    j step_go
.endif

# ---------------------------------------------------------------------------------------------
# NEXT (t3 = slot): IC found no hit in the leaf. Reload the ray and go on with `step`, which
# first checks the leaf (t_max, sub-grid end), then moves on.

on_next:
    { slli sp, t3, SLOT_SHIFT ; mov slot, t3 }
    { addi sp, sp, SLOT_TABLE }
    { ld oox, [sp + S_OO] ; ld ooy, [sp + (S_OO + 1)] }
    { ld ooz, [sp + (S_OO + 2)] ; ld iix, [sp + S_II] }
    { ld iiy, [sp + (S_II + 1)] ; ld iiz, [sp + (S_II + 2)] }
    { ld stx, [sp + S_ST] ; ld sty, [sp + (S_ST + 1)] }
    { ld stz, [sp + (S_ST + 2)] ; ld stmax, [sp + S_STMAX] }
    { ld kbx, [sp + S_KB] ; ld kby, [sp + (S_KB + 1)] }
    { ld kbz, [sp + (S_KB + 2)] ; ld addr, [sp + S_ADDR] }
    { ld m1, [sp + S_TCUR] ; ld tz, [sp + S_TCUR] }      # `m1 < tz ? m1 : tz` = the leaf's exit t
    { ld insub, [sp + S_INSUB] ; mov cont, stepaddr }
.if HAS_SUBGRIDS
    bnez insub, next_sub
.endif
    TOP_LEVEL
    { fmov lexit, finf ; fmov lim, stmax ; j step }
.if HAS_SUBGRIDS
next_sub:
    { ld t0, [sp + S_SUB_HDR] ; ld lexit, [sp + S_SUB_EXIT] }
    { ld lim, [sp + S_SUB_LIM] ; ld lRx, [sp + S_SUB_R] }
    { ld llox, [t0 + SG_LO] ; ld lloy, [t0 + (SG_LO + 1)] }
    { ld lloz, [t0 + (SG_LO + 2)] ; ld lcx, [t0 + SG_CELL] }
    { ld lcy, [t0 + (SG_CELL + 1)] ; ld lcz, [t0 + (SG_CELL + 2)] }
    { ld lRy, [sp + (S_SUB_R + 1)] ; ld lRz, [sp + (S_SUB_R + 2)] }
    { ld dsx, [sp + S_SUB_DS] ; ld dsy, [sp + (S_SUB_DS + 1)] }
    { ld dsz, [sp + (S_SUB_DS + 2)] ; j step }
.endif

# ---------------------------------------------------------------------------------------------
# The ray ends at OS: a surface ray left (or missed) the grid -> MISS (pixel, w); a shadow ray
# left the grid or passed t_max unoccluded -> COLOR (pixel, contribution). Free the slot.

.if LEN_MISS != LEN_COLOR
.error "ray_end checks one room for MISS and COLOR"
.endif
ray_end:
    { ld t0, [sp + RAY_INFO] ; room t4, ring }
    { andi t0, t0, 3 ; slti t4, t4, 1 + LEN_MISS }
    { addi t0, t0, -KIND_SHADOW ; li t1, HDR_MISS }
    { li t2, HDR_COLOR ; bnez t4, ray_end_full }
ray_end_send:                                       # (the drain is over: free the slot)
    { fsel t1, t0, t1, t2 ; st slot, [nfree + free_stack] ; addi nfree, nfree, 1 }
    { send ring, t1 ; ld t3, [sp + RAY_PIXEL] }
    { send ring, t3 ; ld t4, [sp + RAY_WR] }
    { send ring, t4 ; ld t1, [sp + RAY_WG] }
    { send ring, t1 ; ld t2, [sp + RAY_WB] }
.if SERIAL_TREES
    addi alive, alive, -1                           # serial mode: the ray is finished
.endif
    { send ring, t2 ; j main }
ray_end_full:
    { li dneed, 1 + LEN_MISS ; li dret, ray_end_send }
    j drain

# ---------------------------------------------------------------------------------------------
# The send FIFO lacks room for the message OS is about to send (dneed words; dret = where it is
# sent from). OS must not block in `send`: SC may be blocked sending to OS, and IC sending to SC
# (a cycle of full FIFOs). So, until the message fits: consume ONE waiting ring message, sending
# nothing — RAY into the overflow queue, DONE frees its slot, SHADED (serial mode) is counted,
# NEXT is put on the deferred list (`main` resumes the ray later) — and check `room` again; with
# nothing waiting just check again (the send FIFO drains on its own). The ray being sent keeps
# its registers: the drain uses only step temporaries (d0..d2, dneed, dret).
drain:
    poll d0, ring
    beqz d0, drain_room
    RING_MSG d0, d1, d2, d0, drain_next, drain_done
.if SERIAL_TREES
    addi d2, d0, TAG_DONE - TAG_SHADED
    beqz d2, drain_shaded
.endif
.if SECONDARY
    # RAY from SC (d1 = pixel): queued (serial mode: counted; queued anyway, as on_ray would
    # once a ray waits in the queue)
.if SERIAL_TREES
    addi alive, alive, 1
.endif
    ENQUEUE d1, d0, d1, drain_room
.else
    j drain_room                                    # (nothing else reaches OS here)
.endif

drain_next:                                         # NEXT (d1 = slot): resume it later
    ld d0, [NDEFER]
    { st d1, [d0 + DEFERRED] ; addi d0, d0, 1 }
    { st d0, [NDEFER] ; j drain_room }

drain_done:                                         # DONE (d1 = slot): as on_done
    { st d1, [nfree + free_stack] ; addi nfree, nfree, 1 }
.if SERIAL_TREES
    slli d1, d1, SLOT_SHIFT
    ld d1, [d1 + (SLOT_TABLE + RAY_INFO)]
    andi d1, d1, 3
    addi d1, d1, -KIND_SHADOW
    bnez d1, drain_room
drain_shaded:
    addi alive, alive, -1
.endif

drain_room:
    room d0, ring
    blt d0, dneed, drain
    jr dret
