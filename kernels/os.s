# kernels/os.s — OS, the object-search stage: two-level uniform-grid traversal (3-D DDA).
#
# Contract: docs/kernels.md (messages, slots), docs/golden.md "Traversal (OS)" (every float
# operation, in order), docs/databases.md (voxel_data). Assembled per scene with the host's
# symbols (host/databases.py) plus -D SLOTS=n (rays in flight, default 8) and -D SERIAL_TREES=1
# (the serial mode, see below; default 0).
#
# Per ray, exactly as host/traversal.py does it for a whole wavefront:
#   setup   inv = 1/d, which axes step, the grid-entry slab, t_enter, the start voxel
#   step    one leaf per step: its voxel word, the exit axis from the three boundary crossings
#           t_x, t_y, t_z of the voxel, the step along that axis. The crossings are kept a step
#           ahead per axis (see `step`): a step moves the stepped axis's next crossing in and
#           starts the one after; the other two axes' are unchanged. A non-empty leaf A and the
#           ray's next one, B, go to IC as one VISIT_FIRST / VISIT (LOOKAHEAD; B = CELL_NONE if
#           the ray ends at OS first); the ray then sleeps in its slot until IC answers NEXT (go
#           on after the leaves) or DONE (free the slot), and OS works on other rays meanwhile.
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
#   * the boundary a voxel is left through is always lo + float(kb)*cell with kb = index + up
#     (up = 1 on an axis stepping up; golden: index + 1 up, index down); the loop keeps kn =
#     kb + 3 st (the index of the next crossing it will start), and "the index left 0..res-1"
#     after a step (one step from inside) is the one compare kn == kend, kend = res + up + 3
#     stepping up, -4 stepping down (never met on a non-stepping axis);
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
#   setup            a new ray: 1/d (x and y start dividing as the ray is received), stepping
#                    classes, grid entry, start voxel (setup_nonstep: the golden inside test
#                    for axes that do not step), the level's first voxel (LEVEL_START)
#   xblk, yblk, zblk the step loop, one block per exit axis (see `step`)
#   leaf_x.., leaf_end  the previous leaf reached t_max (shadow ray done) or ended its sub-grid
#   level_out        the index left the level: leave_sub (back to the top level) or ray_end
#   ne_x, ne_y, ne_z a non-empty voxel: leaf A (look ahead, LOOKAHEAD), leaf B (ne_xb...:
#                    B_VISIT), a divided voxel (ne_xs...: sub_enter); without LOOKAHEAD
#                    nonempty: VISIT / VISIT_FIRST with B = CELL_NONE at once
#   B_VISIT          leaf B: save the state, VISIT / VISIT_FIRST with both leaves (pair_out);
#                    la_abort (from ray_end): the ray ends at OS, A alone
#   on_next          NEXT from IC: reload the ray's state from its slot (SAVE_STEP: its
#                    crossings too), on with the dispatch
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
# is assembled. The serial mode also recomputes a resumed ray's crossings instead of saving them
# (SAVE_STEP = 0), so that OS's local-memory reads and writes stay those of the paper's trace.
#
# Cost (balls, 32x32): ~105 cycles per ray setup (with its first voxel's crossings), 8-11 per
# empty voxel (8 for a step along x after one along x), ~22 from leaf B to its VISIT sent, ~30
# to resume after NEXT, ~77 to enter a sub-grid (with the top step), ~20 to leave it.

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
# Two leaves per VISIT (docs/kernels.md "Messages"): after a non-empty leaf A, OS steps on to the
# next one, B, and sends both in one message; the serial mode does not (its reads stay those of
# the paper's trace): every VISIT's leaf B is then CELL_NONE.
.ifndef LOOKAHEAD
.equ LOOKAHEAD, !SERIAL_TREES
.endif
.if LOOKAHEAD && SERIAL_TREES
.error "the serial mode sends one leaf per VISIT (no LOOKAHEAD)"
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
#   EXT_TABLE ..              SAVE_STEP: the slots' extensions, SLOTS records of SLOT_WORDS words
#                             (a slot's extension is at the same distance EXT from its record)
#   NDEFER, DEFERRED ..       the last SLOTS + 1 words: the deferred NEXTs (see drain): their
#                             count, then the slots (one NEXT per slot at most)

# Save / restore the step's crossings (T, N, P of every axis, see `step`) in the slot's extension
# when a ray waits for IC and when it enters a sub-grid (the default); the serial mode recomputes
# them from kn instead, so that its local-memory reads and writes stay those of the paper's trace.
.ifndef SAVE_STEP
.equ SAVE_STEP, !SERIAL_TREES
.endif
.equ SLOT_SHIFT, 6
.equ SLOT_WORDS, 1 << SLOT_SHIFT
.equ SLOT_TABLE, OS_FREE_BASE
.equ QUEUE_BASE, SLOT_TABLE + SLOTS * SLOT_WORDS
.equ QUEUE_ENTRY, 16
.equ NDEFER, OS_LOCAL_WORDS - SLOTS - 1
.equ DEFERRED, NDEFER + 1
.if SAVE_STEP
.equ EXT_TABLE, NDEFER - SLOTS * SLOT_WORDS
.else
.equ EXT_TABLE, NDEFER
.endif
.equ EXT, EXT_TABLE - SLOT_TABLE                # [sp + EXT + k]: word k of the slot's extension
.equ QUEUE_CAP, (EXT_TABLE - QUEUE_BASE) / QUEUE_ENTRY
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
.equ S_KB, 28                   # 3: \ saved when a visit goes out: kn and voxel-word address
.equ S_ADDR, 31                 #    | of the next voxel of the current level, the visited
.equ S_TCUR, 32                 #   /  voxel's exact exit t
.equ S_TOP_R, 33                # 3: top level: kend (the kn of an index past the grid)
.equ S_TOP_DS, 36               # 3: top level: address steps st_x, st_y*nx, st_z*nx*ny
.equ S_TOP_KB, 39               # 3: \ the top level (kn, address) while the ray is in a sub-grid
.equ S_TOP_ADDR, 42             #   /  (already stepped past the divided voxel)
.equ S_SUB_HDR, 43              # the sub-grid's header address (its lo and cell)
.equ S_SUB_R, 44                # 3: sub level: kend
.equ S_SUB_DS, 47               # 3: sub level: address steps st_x, st_y*mx, st_z*mx*my
.equ S_SUB_EXIT, 50             # the divided top voxel's exact T_exit
.equ S_SUB_LIM, 51              # t_max < T_exit ? t_max : T_exit (see `lim`)
.equ S_LA_CELL, 52              # LOOKAHEAD: leaf A's list pointer and t_exit while OS looks for
.equ S_LA_TEXIT, 53             #   leaf B
# the slot's extension (SAVE_STEP; offsets from sp too):
.equ S_TT, EXT + 0              # 3 x 3: the step's T, N, P (see `step`) with S_KB
.equ S_NN, EXT + 3
.equ S_PP, EXT + 6
.equ S_TOP_TT, EXT + 9          # 3 x 3: the top level's T, N, P with S_TOP_KB
.equ S_TOP_NN, EXT + 12
.equ S_TOP_PP, EXT + 15
.equ S_CODE, EXT + 18           # with S_KB: 0 = resume at the next voxel's word, else the leaf or
                                #   index check fails (resume_slow)
.equ S_TOP_OOR, EXT + 19        # with S_TOP_KB: the top index left the grid
.if S_LA_TEXIT >= SLOT_WORDS || (SAVE_STEP && S_TOP_OOR - EXT >= SLOT_WORDS)
.error "the slot record does not fit SLOT_WORDS"
.endif

.data
free_stack: .space SLOTS        # indices of the free slots: nfree of them
top_rm:     .space 3            # float(res_a - 1): the top level's start-index clamp bounds
.if SAVE_STEP
top_ke:     .space 6            # the top level's kend per axis: stepping down (or not), up
.endif
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
.reg kf       = r8              # step temporary: float(kn) of the stepping axis (one block's)
# look-ahead (LOOKAHEAD): 1 while OS looks for leaf B, else 0
.reg labm     = r9
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
.reg kex      = r29             # kend: the kn of an index just outside the level (res + up + 3
.reg key      = r30             #   stepping up, -4 stepping down; never met on a non-stepping
.reg kez      = r31             #   axis)
.reg dsx      = r32             # voxel-word address change of a step along each axis
.reg dsy      = r33
.reg dsz      = r34
.reg lexit    = r35             # in a sub-grid: the divided top voxel's T_exit; top: +inf
.reg lim      = r36             # t_max < lexit ? t_max : lexit (see leaf_end)
.reg knx      = r37             # kb + 3 st, kb = voxel index + up (see `step`)
.reg kny      = r38
.reg knz      = r39
.reg addr     = r40             # address of the current voxel's word
.reg tcur     = r41             # a non-empty voxel's exact exit t
.reg tprev    = r42             # the current voxel's t_enter (the previous voxel's exit t)
.reg cx       = r43             # the exit axis is x: tx <= min(ty, tz)
.reg lend     = r44             # the previous voxel's exit t reached lim (see leaf_end)
.reg tb       = r43             # (pair_out: leaf B's t_exit; cx is dead there)
.reg oor      = r45             # (nonempty: the next voxel's index is outside the level)
.reg tx       = r46             # T: the current voxel's boundary crossings
.reg ty       = r47
.reg tz       = r48
.reg vw       = r49             # its voxel word
.reg nnx      = r50             # N: the next crossings
.reg nny      = r51
.reg nnz      = r52
.reg cyz      = r53             # ty <= tz
.reg myz      = r54             # fmin(ty, tz) (only compared)
.reg ppx      = r55             # P: the products float(kb + 2 st)*cell
.reg ppy      = r56
.reg ppz      = r57
# general temporaries (message handling)
.reg t0       = r58
.reg t1       = r59
.reg t2       = r60
.reg t3       = r61
.reg t4       = r62
# the drain (a message waits for room in the send FIFO): step registers, dead on every send path
# (the state is saved first)
.reg d0       = r46             # (tx, ty, tz)
.reg d1       = r47
.reg d2       = r48
.reg dneed    = r53             # words the message needs (cyz)
.reg dret     = r54             # where it is sent from (myz)
# a ray on its way into a slot (only while it starts)
.reg one      = r49             # 1.0 for the setup's divisions
.reg ivx      = r46             # 1/d (x and y start dividing as the ray arrives)
.reg ivy      = r47
.reg ivz      = r48
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
    li labm, 0
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
.if SAVE_STEP
    { ld t0, [VOXEL_BASE + VD_RES] ; ld t1, [VOXEL_BASE + (VD_RES + 1)] }
    { ld t2, [VOXEL_BASE + (VD_RES + 2)] ; li t3, -4 }
    { addi t0, t0, 4 ; addi t1, t1, 4 }
    { addi t2, t2, 4 ; st t3, [top_ke] }
    { st t0, [top_ke + 1] ; st t3, [top_ke + 2] }
    { st t1, [top_ke + 3] ; st t3, [top_ke + 4] }
    st t2, [top_ke + 5]
.endif

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
    { beqz t0, no_ring ; sltu t2, r0, nfree }      # t2 = a slot is free
# a ring message: NEXT and DONE known by their whole header word
ring_msg:
    { recv t0, ring ; li t1, HDR_NEXT }             # header
    { recv slot, ring ; li t2, HDR_DONE }           # first payload word (NEXT, DONE: the slot)
    beq t0, t1, on_next
    { srli t0, t0, HDR_TAG_SHIFT ; beq t0, t2, on_done }
.if SERIAL_TREES
    addi t1, t0, -TAG_SHADED
    beqz t1, on_shaded
.endif
.if SECONDARY
    j on_ray
.else
    j main                                          # (nothing else reaches OS here)
.endif

no_ring:
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
    j ring_msg

# a deferred NEXT (t1 = ndefer > 0): resume the ray as if its NEXT had just arrived
from_defer:
    { ld slot, [t1 + (DEFERRED - 1)] ; addi t1, t1, -1 }
    { st t1, [NDEFER] ; j on_next }

# DONE (slot): the ray ended at IC (a hit, or an occluded shadow ray)
on_done:
    { st slot, [nfree + free_stack] ; addi nfree, nfree, 1 }
.if SERIAL_TREES
    slli t1, slot, SLOT_SHIFT                         # serial mode: an occluded shadow ray ends
    ld t1, [t1 + (SLOT_TABLE + RAY_INFO)]           #   here; a surface ray's hit ends with
    andi t1, t1, 3                                  #   its SHADED
    addi t1, t1, -KIND_SHADOW
    bnez t1, main
    { addi alive, alive, -1 ; j main }

# SHADED (serial mode; slot = pixel): SC has shaded a hit and sent every ray it spawned
on_shaded:
    { addi alive, alive, -1 ; j main }
.else
    j main
.endif

# The middle of a RAY message, words 4..11 (o.z, d, t_min, t_max, w.r, w.g), from `port` into the
# ray registers, one a bundle (a new ray from SC on the ring or from the host); 1/d_x and 1/d_y
# start dividing (one = 1.0).
.macro RECV_RAY port
    { recv roz, \port ; lf one, 1.0 }
    recv rdx, \port
    recv rdy, \port
    { recv rdz, \port ; fdiv ivx, one, rdx }     # (setup's 1/d: the divider is not
    { recv rtmin, \port ; fdiv ivy, one, rdy }   #  pipelined, so x and y start here)
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
# RAY from SC (slot = its pixel word): start it in a free slot, or queue it
on_ray:
.if SERIAL_TREES
    { addi alive, alive, 1 ; bnez qcount, enqueue } # serial mode: strictly first come, first served
.endif
    beqz nfree, enqueue
    { addi nfree, nfree, -1 ; mov rpix, slot }
    { ld slot, [nfree + free_stack] ; recv rinfo, ring }
    { slli sp, slot, SLOT_SHIFT ; recv rox, ring }
    { addi sp, sp, SLOT_TABLE ; recv roy, ring }
    RECV_RAY ring
    { recv rwb, ring ; j setup }

enqueue:
    ENQUEUE slot, t0, t1, main

queue_overflow:                 # more rays wait than OS memory holds: stop the run with a
    ld t0, [r0 - 1]             # memory fault whose report names this label

# the oldest queued ray takes a free slot
from_queue:
    { addi nfree, nfree, -1 ; lf one, 1.0 }
    { ld rdx, [qhead + 5] ; ld rdy, [qhead + 6] }
    { ld slot, [nfree + free_stack] ; ld rpix, [qhead + 0] }
    { ld rinfo, [qhead + 1] ; fdiv ivx, one, rdx }
    { ld rox, [qhead + 2] ; fdiv ivy, one, rdy }
    { ld roy, [qhead + 3] ; ld roz, [qhead + 4] }
    { ld rdz, [qhead + 7] ; ld rtmin, [qhead + 8] }
    { ld rtmax, [qhead + 9] ; ld rwr, [qhead + 10] }
    { ld rwg, [qhead + 11] ; ld rwb, [qhead + 12] }
    { slli sp, slot, SLOT_SHIFT ; addi qhead, qhead, QUEUE_ENTRY }
    { addi sp, sp, SLOT_TABLE ; li qend, QUEUE_END }
    { addi qcount, qcount, -1 ; bne qhead, qend, setup }
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
    recv rwb, host

# ---------------------------------------------------------------------------------------------
# The step's state (see `step` below) as linear code for `.sched` regions

# A level's first voxel from kb (in kn's registers, kb_a = index + up_a): per axis T = crossing(kb),
# N = crossing(kb + st), P = float(kb + 2 st)*cell, kn = kb + 3 st; crossing(k) = (lo + float(k)*cell
# - o) * inv, golden's operations in its order
.macro AXIS_START t, n, p, kn, st, lo, c, o, ii
    itof \t, \kn
    add \kn, \kn, \st
    itof \n, \kn
    add \kn, \kn, \st
    itof \p, \kn
    add \kn, \kn, \st
    CROSSINGS \t, \n, \p, \lo, \c, \o, \ii
.endm

# the same from kn (a resumed ray without SAVE_STEP; k: a temporary)
.macro AXIS_FROM_KN t, n, p, kn, st, lo, c, o, ii, k
    sub \k, \kn, \st
    itof \p, \k
    sub \k, \k, \st
    itof \n, \k
    sub \k, \k, \st
    itof \t, \k
    CROSSINGS \t, \n, \p, \lo, \c, \o, \ii
.endm

.macro CROSSINGS t, n, p, lo, c, o, ii
    fmul \t, \t, \c
    fadd \t, \lo, \t
    fsub \t, \t, \o
    fmul \t, \t, \ii
    fmul \n, \n, \c
    fadd \n, \lo, \n
    fsub \n, \n, \o
    fmul \n, \n, \ii
    fmul \p, \p, \c
.endm

.macro STEP_FROM_KN
    AXIS_FROM_KN tx, nnx, ppx, knx, stx, llox, lcx, oox, iix, t0
    AXIS_FROM_KN ty, nny, ppy, kny, sty, lloy, lcy, ooy, iiy, t1
    AXIS_FROM_KN tz, nnz, ppz, knz, stz, lloz, lcz, ooz, iiz, t2
.endm

# the exit-axis flags of the current voxel
.macro FLAGS
    fmin myz, ty, tz
    fle cyz, ty, tz
    fle cx, tx, myz
.endm

# a level's first voxel: its crossings, flags and word (no leaf or index check: kb is clamped)
.macro LEVEL_START
    AXIS_START tx, nnx, ppx, knx, stx, llox, lcx, oox, iix
    AXIS_START ty, nny, ppy, kny, sty, lloy, lcy, ooy, iiy
    AXIS_START tz, nnz, ppz, knz, stz, lloz, lcz, ooz, iiz
    FLAGS
    ld vw, [addr]
.endm

# SAVE_STEP: the crossings into / from the slot (words t, n, p: 3 each): `op` = st or ld, one
# word a line (STORE_STEP_B: the stores two a bundle, for hand-bundled code)
.macro STEP_WORDS op, t, n, p
    \op tx, [sp + \t]
    \op ty, [sp + (\t + 1)]
    \op tz, [sp + (\t + 2)]
    \op nnx, [sp + \n]
    \op nny, [sp + (\n + 1)]
    \op nnz, [sp + (\n + 2)]
    \op ppx, [sp + \p]
    \op ppy, [sp + (\p + 1)]
    \op ppz, [sp + (\p + 2)]
.endm
.macro STORE_STEP_B t, n, p
    { st tx, [sp + \t] ; st ty, [sp + (\t + 1)] }
    { st tz, [sp + (\t + 2)] ; st nnx, [sp + \n] }
    { st nny, [sp + (\n + 1)] ; st nnz, [sp + (\n + 2)] }
    { st ppx, [sp + \p] ; st ppy, [sp + (\p + 1)] }
    st ppz, [sp + (\p + 2)]
.endm

# The top level's traversal state into the level registers: its lo corner and cell size (the
# voxel data's header) and the ray's kend and voxel-address steps there (its slot).
.macro TOP_LEVEL_OPS
    ld llox, [VOXEL_BASE + VD_LO]
    ld lloy, [VOXEL_BASE + (VD_LO + 1)]
    ld lloz, [VOXEL_BASE + (VD_LO + 2)]
    ld lcx, [VOXEL_BASE + VD_CELL]
    ld lcy, [VOXEL_BASE + (VD_CELL + 1)]
    ld lcz, [VOXEL_BASE + (VD_CELL + 2)]
    ld kex, [sp + S_TOP_R]
    ld key, [sp + (S_TOP_R + 1)]
    ld kez, [sp + (S_TOP_R + 2)]
    ld dsx, [sp + S_TOP_DS]
    ld dsy, [sp + (S_TOP_DS + 1)]
    ld dsz, [sp + (S_TOP_DS + 2)]
.endm

# V's exit axis: its block (after a level's first voxel and a resumed ray): the region's last
# line (with the word's load), then DISPATCH
.macro DISPATCH_X
    bnez cx, xblk
.endm
.macro DISPATCH
    beqz cyz, zblk
    j yblk
.endm

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
    # while x and y divide (both FP units busy: the divider is not pipelined), integer work only:
    # the grid's corners, the record into the slot (hx, hy and s0 take rpix, rwr and rwb: stored
    # first); then list-scheduled from 1/d_z on
    { ld llox, [VOXEL_BASE + VD_LO] ; st rpix, [sp + RAY_PIXEL] }
    { ld hx, [VOXEL_BASE + VD_HI] ; st rwr, [sp + RAY_WR] }
    { ld lloy, [VOXEL_BASE + (VD_LO + 1)] ; st rwb, [sp + RAY_WB] }
    { ld hy, [VOXEL_BASE + (VD_HI + 1)] ; st rdx, [sp + RAY_DX] }
.sched
    # t_max (surface rays get NaN: no compare with it is ever true), the slabs and the stepping
    # classes (steps iff 0 < |1/d| < inf; up iff it steps and 1/d > 0)
    fdiv ivz, one, rdz
    st rdy, [sp + RAY_DY]
    st rwg, [sp + RAY_WG]
    ld lloz, [VOXEL_BASE + (VD_LO + 2)]
    ld hz, [VOXEL_BASE + (VD_HI + 2)]
    fsub tax, llox, rox
    fsub tbx, hx, rox
    fsub tay, lloy, roy
    andi s0, rinfo, 3
    addi s0, s0, -KIND_SHADOW
    sel stmax, s0, fnan, rtmax
    st rinfo, [sp + RAY_INFO]
    li s0, 1
    st rox, [sp + RAY_OX]
    st roy, [sp + RAY_OY]
    st roz, [sp + RAY_OZ]
    st rdz, [sp + RAY_DZ]
    st rtmin, [sp + RAY_TMIN]
    st rtmax, [sp + RAY_TMAX]
    st stmax, [sp + S_STMAX]
    fsub taz, lloz, roz
    fsub tbz, hz, roz
    fsub tby, hy, roy
    st s0, [sp + S_FIRST]
    st r0, [sp + S_INSUB]
    fabs aa, ivx
    flt ngx, ivx, r0
    flt stpx, r0, aa
    ld lcx, [VOXEL_BASE + VD_CELL]
    flt aa, aa, finf
    ld lcy, [VOXEL_BASE + (VD_CELL + 1)]
    fmul tax, tax, ivx
    and stpx, stpx, aa
    fmul tbx, tbx, ivx
    slt upx, ngx, stpx
    # z's 1/d is ready: both units
    fmul taz, taz, ivz
    fmul tbz, tbz, ivz
    fmul tay, tay, ivy
    fmul tby, tby, ivy
    fabs aa, ivy
    sel oox, stpx, rox, fninf
    flt ngy, ivy, r0
    sel iix, stpx, ivx, finf
    ld lcz, [VOXEL_BASE + (VD_CELL + 2)]
    st oox, [sp + S_OO]
    ld nx, [VOXEL_BASE + VD_RES]
    st iix, [sp + S_II]
    fmin kf, tax, tbx
    fmax tbx, tax, tbx
    fmov tax, kf
    flt stpy, r0, aa
    fabs az, ivz
    flt aa, aa, finf
    flt ngz, ivz, r0
    fmin insub, taz, tbz
    fmax tbz, taz, tbz
    fmov taz, insub
    fmin lim, tay, tby
    fmax tby, tay, tby
    fmov tay, lim
    flt stpz, r0, az
    flt az, az, finf
    flt s0, tay, tax
    and stpy, stpy, aa
    sel tent, s0, tax, tay
    and stpz, stpz, az
    and all, stpx, stpy
    slt upy, ngy, stpy
    and all, all, stpz
    slt upz, ngz, stpz
    sel ooy, stpy, roy, fninf
    beqz all, setup_nonstep
.endsched
setup_tz:
.sched
.deadout r12-r62                                          # (dead at ray_end)
    # t_enter = max(max(max(t_lo_x, t_lo_y), t_lo_z), t_min), numpy's max `a > b ? a : b`;
    # t_far = min(min(t_hi_x, t_hi_y), t_hi_z): only compared, fmin will do
    flt s0, taz, tent
    fmin tbx, tbx, tby
    sel tent, s0, tent, taz
    fmin tbx, tbx, tbz
    flt s0, rtmin, tent
    sel iiy, stpy, ivy, finf
    sel tent, s0, tent, rtmin
    and stpx, stpx, ngx                                   # (stepping down, for the steps)
    fle s0, tent, tbx                                     # t_enter <= t_far
    fle tbz, stmax, tent                                  # t_enter >= t_max (surface: NaN: never)
    slt s0, tbz, s0                                       # alive = the first and not the second
    beqz s0, ray_end                                      # the ray misses the grid
    # start voxel: p = o + t_enter*d; i = floor(clamp((p - lo)*inv_cell, 0, res-1)): clamping
    # before the floor gives the golden floor-then-clamp integer (the bounds are integers); then
    # the level's first voxel (LEVEL_START)
    sel ooz, stpz, roz, fninf
    sel iiz, stpz, ivz, finf
    fmul tax, tent, rdx
    fmul tay, tent, rdy
    fmul taz, tent, rdz
    fadd tax, rox, tax
    and stpy, stpy, ngy
    li insub, 0
    fadd tay, roy, tay
    and stpz, stpz, ngz
    fadd taz, roz, taz
    fsub tax, tax, llox
    fsub tay, tay, lloy
    sub stx, upx, stpx                                    # step = up - down: +1, -1 or 0
    fsub taz, taz, lloz
    sub sty, upy, stpy
    sub stz, upz, stpz
    ld icx, [VOXEL_BASE + VD_INV_CELL]
    ld icy, [VOXEL_BASE + (VD_INV_CELL + 1)]
    ld icz, [VOXEL_BASE + (VD_INV_CELL + 2)]
    fmul tax, tax, icx
    fmul tay, tay, icy
    fmul taz, taz, icz
    st ooy, [sp + (S_OO + 1)]
    ld rmx, [top_rm]
    ld rmy, [top_rm + 1]
    ld rmz, [top_rm + 2]
    ld nxy, [VOXEL_BASE + VD_NXY]
    fmax tax, tax, r0                                     # (r0 = +0.0)
    fmin tax, tax, rmx
    floor tax, tax
    fmax tay, tay, r0
    fmin tay, tay, rmy
    floor tay, tay
    fmax taz, taz, r0
    fmin taz, taz, rmz
    floor taz, taz
    mul dsz, stz, nxy
    # kend = up ? res + 4 : -4 (kn = kb + 3 st meets it when the index leaves 0..res-1; SAVE_STEP:
    # from top_ke); the voxel word's address TOP_VOXELS + ix + iy*nx + iz*nx*ny; the top level's
    # address steps (st_x, st_y*nx, st_z*nx*ny); kb = index + up (in place of up)
.if SAVE_STEP
    ld kex, [upx + top_ke]
    ld key, [upy + (top_ke + 2)]
    ld kez, [upz + (top_ke + 4)]
.else
    ld ny, [VOXEL_BASE + (VD_RES + 1)]
    ld nz, [VOXEL_BASE + (VD_RES + 2)]
    li s0, -4
    addi hz, nx, 4
    sel kex, upx, hz, s0
    addi hz, ny, 4
    sel key, upy, hz, s0
    addi hz, nz, 4
    sel kez, upz, hz, s0
.endif
    mul hx, tay, nx
    mul hy, taz, nxy
    mul dsy, sty, nx
    st upx, [sp + S_UP]
    st upy, [sp + (S_UP + 1)]
    st upz, [sp + (S_UP + 2)]
    add knx, tax, upx
    add kny, tay, upy
    add knz, taz, upz
    addi addr, tax, TOP_VOXELS
    add addr, addr, hx
    add addr, addr, hy
    fmov dsx, stx
    st ooz, [sp + (S_OO + 2)]
    st iiy, [sp + (S_II + 1)]
    st iiz, [sp + (S_II + 2)]
    st stx, [sp + S_ST]
    st sty, [sp + (S_ST + 1)]
    st stz, [sp + (S_ST + 2)]
    fmov tprev, tent
    fmov lexit, finf
    fmov lim, stmax
    st kex, [sp + S_TOP_R]
    st key, [sp + (S_TOP_R + 1)]
    st kez, [sp + (S_TOP_R + 2)]
    st dsx, [sp + S_TOP_DS]
    st dsy, [sp + (S_TOP_DS + 1)]
    st dsz, [sp + (S_TOP_DS + 2)]
    LEVEL_START
    DISPATCH_X
.endsched
    DISPATCH

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
# The step loop: one voxel of the current level per pass.
#
# Per axis a, for the current voxel V (kb_a = V's index + up_a: the index of the boundary V is
# left through along a), the loop keeps
#   T_a  = crossing(kb_a)                  tx, ty, tz
#   N_a  = crossing(kb_a + st_a)           nnx, nny, nnz
#   P_a  = float(kb_a + 2 st_a) * cell_a   ppx, ppy, ppz (the crossing after: its first product)
#   kn_a = kb_a + 3 st_a                   knx, kny, knz
# where crossing(k) = (lo_a + float(k)*cell_a - o_a) * inv_a, golden's operations in its order,
# and myz = fmin(ty, tz), cyz = ty <= tz, cx = tx <= myz: the golden exit axis is x if cx, else y
# if cyz, else z (fmin: only compared, and no crossing is NaN); tprev = V's t_enter, vw = V's word.
# A step along a leaves the other axes' crossings as they are (same inputs, same operations, same
# values): T_a <- N_a, N_a <- (lo_a + P_a - o_a) * inv_a, P_a <- float(kn_a) * cell_a, kn_a +=
# st_a, addr += ds_a, and only the compares with the new T_a are redone. The recurrence is
# compare -> branch: the crossings are ready a step ahead.
# V's exit t is T_a of its exit axis: numpy's min(min(tx, ty), tz) has that value (the two can
# differ only in the sign of a zero, which no compare sees and no index computed from t either);
# the exact min is formed where it leaves OS or becomes a bound (tcur, in ne_x / ne_y / ne_z).
#
# A block (xblk, yblk, zblk: V's exit axis is x, y, z), in the golden order:
#   V non-empty -> ne_x / ne_y / ne_z: the rest of the step there (leaf A, B, or a sub-grid)
#   V's exit t >= lim -> leaf_x / leaf_y / leaf_z (t_max reached, or the sub-grid finished)
#   the next voxel's index is outside the level (kn_a = kend_a) -> level_out
#   the next voxel's word; its exit axis -> its block.
# A level's first voxel (setup, sub_enter: LEVEL_START; leave_sub) and a resumed ray (on_next)
# come in through DISPATCH_X / DISPATCH with all of this set up and the voxel's word read (after
# a resumed ray's leaf and index checks, and leave_sub's index check).
# The blocks are scheduled for the two write ports (at most two results written per bundle and
# completing per cycle; a step writes 12 registers along x, 14 along y or z). A step along x
# takes 8 cycles when the next is along x too.

xblk:
    { fle lend, lim, tx ; fadd ppx, llox, ppx ; bnez vw, ne_x }
    { itof kf, knx ; add knx, knx, stx ; bnez lend, leaf_x }
    { fsub ppx, ppx, oox ; fmov tprev, tx ; beq knx, kex, level_out }
    fmov tx, nnx
    { fmul nnx, ppx, iix ; fle cx, nnx, myz }
    { fmul ppx, kf, lcx ; add addr, addr, dsx }
    { ld vw, [addr] ; bnez cx, xblk }
    beqz cyz, zblk
.macro Y_BLOCK
    { fle lend, lim, ty ; fadd ppy, lloy, ppy ; bnez vw, ne_y }
    { itof kf, kny ; add kny, kny, sty ; bnez lend, leaf_y }
    { fsub ppy, ppy, ooy ; fmov tprev, ty ; beq kny, key, level_out }
    fmin myz, nny, tz
    { fmov ty, nny ; fle cyz, nny, tz }
    { fmul nny, ppy, iiy ; fle cx, tx, myz }
    { fmul ppy, kf, lcy ; add addr, addr, dsy }
    { ld vw, [addr] ; bnez cx, xblk }
    bnez cyz, yblk
.endm
yblk:
    Y_BLOCK
zblk:
    { fle lend, lim, tz ; fadd ppz, lloz, ppz ; bnez vw, ne_z }
    { itof kf, knz ; add knz, knz, stz ; bnez lend, leaf_z }
    { fsub ppz, ppz, ooz ; fmov tprev, tz ; beq knz, kez, level_out }
    fmin myz, ty, nnz
    { fmov tz, nnz ; fle cyz, ty, nnz }
    { fmul nnz, ppz, iiz ; fle cx, tx, myz }
    { fmul ppz, kf, lcz ; add addr, addr, dsz }
    { ld vw, [addr] ; bnez cx, xblk }
    beqz cyz, zblk
    Y_BLOCK                                 # (a second y block: z -> y falls through)
    j zblk


# V is non-empty (its block's first bundle done: lend, lo + P_a). V's exact exit t tcur is numpy's
# min(min(tx, ty), tz); knowing the exit axis: x: `tx < tz ? (tx < ty ? tx : ty) : tz`; y: tx >= ty
# there, so `ty < tz ? ty : tz`; z: ty > tz and tx > tz, so tz. The leaf's t_exit t3: top level
# tcur; in a sub-grid numpy's min(tn, T_exit), `tn < T ? tn : T`.
.if LOOKAHEAD
# Leaf A (labm = 0, vw > 0): its list pointer and t_exit into the slot, labm = 1, then the rest
# of its block (the step, the leaf check with tprev = V's exit t, the index check, the next word:
# "look-ahead", see nonempty), one region per axis (.deadout: the registers the region writes
# after an exit are dead at leaf_end and level_out). Leaf B or a divided voxel: ne_xb / ne_xs ...
ne_x:
.if HAS_SUBGRIDS
    { flt t1, tx, ty ; flt t2, tx, tz ; blt vw, r0, ne_xs }
.else
    { flt t1, tx, ty ; flt t2, tx, tz }
.endif
    { fsel tcur, t1, tx, ty ; bnez labm, ne_xb }
.sched
.deadout r8, r43, r46, r50, r55
    fsel tcur, t2, tcur, tz
    flt t1, tcur, lexit
    fsel t3, t1, tcur, lexit
    st vw, [sp + S_LA_CELL]
    st t3, [sp + S_LA_TEXIT]
    li labm, 1
    itof kf, knx
    add knx, knx, stx
    fmov tprev, tx
    bnez lend, leaf_end
    beq knx, kex, level_out
    fsub ppx, ppx, oox
    fle cx, nnx, myz
    fmov tx, nnx
    fmul nnx, ppx, iix
    fmul ppx, kf, lcx
    add addr, addr, dsx
    ld vw, [addr]
    bnez cx, xblk
.endsched
    beqz cyz, zblk
    j yblk
ne_y:
.if HAS_SUBGRIDS
    { flt t1, ty, tz ; blt vw, r0, ne_ys }
.else
    { flt t1, ty, tz }
.endif
    { fsel tcur, t1, ty, tz ; bnez labm, ne_yb }
.sched
.deadout r8, r43, r47, r51, r53, r54, r56
    flt t1, tcur, lexit
    fsel t3, t1, tcur, lexit
    st vw, [sp + S_LA_CELL]
    st t3, [sp + S_LA_TEXIT]
    li labm, 1
    itof kf, kny
    add kny, kny, sty
    fmov tprev, ty
    bnez lend, leaf_end
    beq kny, key, level_out
    fsub ppy, ppy, ooy
    fmin myz, nny, tz
    fle cyz, nny, tz
    fmov ty, nny
    fle cx, tx, myz
    fmul nny, ppy, iiy
    fmul ppy, kf, lcy
    add addr, addr, dsy
    ld vw, [addr]
    bnez cx, xblk
.endsched
    bnez cyz, yblk
    j zblk
ne_z:
.if HAS_SUBGRIDS
    { flt t1, tz, lexit ; blt vw, r0, ne_zs }
.else
    { flt t1, tz, lexit }
.endif
    { fsel t3, t1, tz, lexit ; bnez labm, ne_zb }
.sched
.deadout r8, r43, r48, r52, r53, r54, r57
    st vw, [sp + S_LA_CELL]
    st t3, [sp + S_LA_TEXIT]
    li labm, 1
    itof kf, knz
    add knz, knz, stz
    fmov tprev, tz
    bnez lend, leaf_end
    beq knz, kez, level_out
    fsub ppz, ppz, ooz
    fmin myz, ty, nnz
    fle cyz, ty, nnz
    fmov tz, nnz
    fle cx, tx, myz
    fmul nnz, ppz, iiz
    fmul ppz, kf, lcz
    add addr, addr, dsz
    ld vw, [addr]
    bnez cx, xblk
.endsched
    beqz cyz, zblk
    j yblk
.endif

# Leaf B's VISIT (region lines; tb = B's t_exit): the state after B (before the drain, which takes
# the crossings' registers), then both leaves (pair_send after a drain; pair_first: VISIT_FIRST).
.macro B_VISIT
    room t4, ring
    ld t0, [sp + S_FIRST]
    st knx, [sp + S_KB]
    st kny, [sp + (S_KB + 1)]
    st knz, [sp + (S_KB + 2)]
    st addr, [sp + S_ADDR]
    st tcur, [sp + S_TCUR]
.if SAVE_STEP
    STEP_WORDS st, S_TT, S_NN, S_PP
    or t3, lend, oor
    st t3, [sp + S_CODE]
.endif
    slti t2, t4, 1 + LEN_VISIT
    li t1, HDR_VISIT
    li labm, 0
    bnez t0, pair_first
    bnez t2, pair_full
    ld t3, [sp + S_LA_CELL]
    ld t2, [sp + S_LA_TEXIT]
    send ring, t1
    send ring, slot
    send ring, t3
    send ring, t2
    send ring, vw
    send ring, tb
    j main
.endm

# The step past a non-empty voxel V along its exit axis, for the paths that leave the loop
# (linear assembly, in their regions): V's exact exit t (tcur: numpy's min of its crossings,
# `a < b ? a : b`; x, y, z in the exit-axis rule's order), then AXIS_STEP: the axis's crossings
# move on (T = N, N finished with golden's operations, the next P started), its index and the
# word address; oor = the index left the level.
.macro AXIS_STEP a
    itof kf, kn\a
    add kn\a, kn\a, st\a
    fsub pp\a, pp\a, oo\a
    fmov t\a, nn\a
    fmul nn\a, pp\a, ii\a
    fmul pp\a, kf, lc\a
    add addr, addr, ds\a
    seq oor, kn\a, ke\a
.endm
.macro STEP_PAST_X
    flt t1, tx, ty
    flt t2, tx, tz
    fsel tcur, t1, tx, ty
    fsel tcur, t2, tcur, tz
    AXIS_STEP x
.endm
.macro STEP_PAST_Y
    flt t1, ty, tz
    fsel tcur, t1, ty, tz
    AXIS_STEP y
.endm
.macro STEP_PAST_Z
    fmov tcur, tz
    AXIS_STEP z
.endm

.if LOOKAHEAD
# Leaf B (ne_xb / ne_yb / ne_zb, labm = 1, vw > 0): the step past it (its flags are not needed:
# a resumed ray recomputes them), its t_exit tb, then the VISIT with both leaves (B_VISIT); a
# divided voxel: ne_xs / ne_ys / ne_zs (below sub_enter).
.macro NE_END
    flt t1, tcur, lexit
    fsel tb, t1, tcur, lexit
    B_VISIT
.endm
.sched
ne_xb:
    STEP_PAST_X
    NE_END
ne_yb:
    STEP_PAST_Y
    NE_END
ne_zb:
    STEP_PAST_Z
    NE_END
.endsched
.else
# Without LOOKAHEAD: the whole step past a non-empty V (tcur, oor = the next voxel's index is
# outside the level; tprev stays V's t_enter for sub_enter; no flags), then nonempty.
.macro NE_END
    j nonempty
.endm
.sched
ne_x:
    STEP_PAST_X
    NE_END
ne_y:
    STEP_PAST_Y
    NE_END
ne_z:
    STEP_PAST_Z
    NE_END
.endsched
.endif

# The previous voxel's exit t (tprev) reached lim = min(t_max, lexit) (lend). In the golden order:
#   the leaf's t_exit = min(tprev, lexit) (top level: lexit = +inf) >= t_max: a shadow ray is
#     done, unoccluded (surface rays: t_max is NaN, never);
#   tprev >= lexit: the sub-grid is finished (golden sub_end).
# Given lend the first holds exactly when t_max <= lexit (t_max < lexit: lim = t_max <= tprev,
# and both operands of the min are >= t_max; else lim = lexit <= tprev and the min is lexit), and
# otherwise the second does: so the leaf check is t_max <= lexit, then level_out.
# leaf_x / leaf_y / leaf_z: from the blocks, V's exit t is T_a (not yet moved) -> tprev.
.macro LEAF_TAIL
    bnez t0, ray_end
.if HAS_SUBGRIDS
    bnez insub, leave_sub
.endif
    j ray_end
.endm
leaf_x:
    { fmov tprev, tx ; fle t0, stmax, lexit }
    LEAF_TAIL
leaf_y:
    { fmov tprev, ty ; fle t0, stmax, lexit }
    LEAF_TAIL
leaf_z:
    { fmov tprev, tz ; fle t0, stmax, lexit }
    LEAF_TAIL
leaf_end:
    fle t0, stmax, lexit
    LEAF_TAIL

# The index left the level, or the sub-grid is finished.
level_out:
.if HAS_SUBGRIDS
    bnez insub, leave_sub
.endif
    j ray_end

.if HAS_SUBGRIDS
# Back to the top level, which was stepped past the divided voxel when the ray entered its
# sub-grid; its t_enter is the divided voxel's T_exit (lexit). Its crossings: saved by sub_enter
# (SAVE_STEP) or recomputed from kn; then the index check (the top step may have left the grid;
# no leaf check: the level's first voxel here) and the word.
leave_sub:
.sched
    ld knx, [sp + S_TOP_KB]
    ld kny, [sp + (S_TOP_KB + 1)]
    ld knz, [sp + (S_TOP_KB + 2)]
    ld addr, [sp + S_TOP_ADDR]
    TOP_LEVEL_OPS
.if SAVE_STEP
    STEP_WORDS ld, S_TOP_TT, S_TOP_NN, S_TOP_PP
    ld t0, [sp + S_TOP_OOR]
.else
    STEP_FROM_KN
.endif
    fmov tprev, lexit
    li insub, 0
    st r0, [sp + S_INSUB]
    fmov lexit, finf
    fmov lim, stmax
    FLAGS
.if SAVE_STEP
    bnez t0, level_out
.else
    beq knx, kex, level_out
    beq kny, key, level_out
    beq knz, kez, level_out
.endif
    ld vw, [addr]
    DISPATCH_X
.endsched
    DISPATCH
.endif

# ---------------------------------------------------------------------------------------------
# A non-empty voxel V, from ne_x / ne_y / ne_z: the step past it is done (kn, addr, the
# crossings), tcur = its exact exit t, tprev = its t_enter, lend = tcur >= lim, oor = the next
# voxel's index is outside the level. vw > 0: a leaf -> VISIT; vw < 0 (top level only): a
# divided voxel -> its sub-grid.

# OS never blocks in `send` (docs/kernels.md "Deadlock freedom"): `room` first; a message that
# does not fit its send FIFO whole waits in `drain`, which keeps reading the ring meanwhile.

.if LOOKAHEAD
# Leaf A (ne_x / ne_y / ne_z) went into the slot, and the ray stepped on ("look-ahead", labm = 1)
# as after a NEXT. The look-ahead goes on through empty voxels, sub_enter and leave_sub, so every
# step it takes is one the ray needs after a NEXT anyway; it ends at leaf B (B_VISIT in ne_xb /
# ne_yb / ne_zb: the pair) or where the ray would end at OS (ray_end -> la_abort: A alone).
# Every end saves the resume state.
# t0 = the slot's S_FIRST, t4 = room; vw, tb = cell_B, t_exit_B (A's words are in the slot)
pair_out:
    { li t1, HDR_VISIT ; slti t2, t4, 1 + LEN_VISIT }
    bnez t0, pair_first
    bnez t2, pair_full
pair_send:
    { send ring, t1 ; ld t3, [sp + S_LA_CELL] }
    { send ring, slot ; ld t2, [sp + S_LA_TEXIT] }
    { send ring, t3 }
    { send ring, t2 }
    { send ring, vw }
    { send ring, tb ; j main }
pair_full:
    { li dneed, 1 + LEN_VISIT ; li dret, pair_send }
    j drain

# The look-ahead reached ray_end (the ray would end at OS: a shadow ray's t_max, or it leaves the
# grid): save the state there (kn and tprev as the leaf or index check found them, so a NEXT
# resumes there and comes to ray_end again; the crossings are not needed then) and send A alone.
la_abort:
    { st knx, [sp + S_KB] ; st kny, [sp + (S_KB + 1)] }
    { st knz, [sp + (S_KB + 2)] ; st addr, [sp + S_ADDR] ; fmov tb, r0 }
    { st tprev, [sp + S_TCUR] ; ld t0, [sp + S_FIRST] }
    { room t4, ring ; li vw, CELL_NONE }
.if SAVE_STEP
    { li t2, 1 ; li labm, 0 }
    { st t2, [sp + S_CODE] ; j pair_out }
.else
    { li labm, 0 ; j pair_out }
.endif

# the first visit carries the ray record (t4 = room)
pair_first:
    { li t1, HDR_VISIT_FIRST ; slti t2, t4, 1 + LEN_VISIT_FIRST }
    bnez t2, first_full
first_send:
    { send ring, t1 ; ld t3, [sp + S_LA_CELL] }
    { send ring, slot ; ld t2, [sp + S_LA_TEXIT] }
    { send ring, t3 ; st r0, [sp + S_FIRST] }
    { send ring, t2 ; ld t1, [sp + 0] }
.rept 6                                             # the ray record, words 1..12: t1 and t2
    { ld t2, [sp + (2 * \+ + 1)] ; send ring, t1 }   #   take turns, one loaded while the
    { ld t1, [sp + (2 * \+ + 2)] ; send ring, t2 }   #   other is sent
.endr
    { send ring, t1 }
    { send ring, vw }
    { send ring, tb ; j main }
first_full:
    { li dneed, 1 + LEN_VISIT_FIRST ; li dret, first_send }
    j drain

.else
# No look-ahead (the serial mode): one leaf per VISIT, cell_B = CELL_NONE.
nonempty:
    { ld t0, [sp + S_FIRST] ; st knx, [sp + S_KB] }
.if HAS_SUBGRIDS
    { room t4, ring ; blt vw, r0, sub_enter }
.else
    room t4, ring
.endif
.if SAVE_STEP
    STORE_STEP_B S_TT, S_NN, S_PP
    or t2, lend, oor
    st t2, [sp + S_CODE]
.endif
    # the leaf's t_exit: top level tcur; in a sub-grid numpy's min(tn, T_exit), `tn < T ? tn : T`
    { flt t3, tcur, lexit ; li t1, HDR_VISIT ; bnez t0, visit_first }
    { fsel tb, t3, tcur, lexit ; slti t2, t4, 1 + LEN_VISIT }
    { bnez t2, visit_full ; st kny, [sp + (S_KB + 1)] }
visit_send:
    { send ring, t1 ; st knz, [sp + (S_KB + 2)] }
    { send ring, slot ; st addr, [sp + S_ADDR] }
    { send ring, vw ; st tcur, [sp + S_TCUR] }
    { send ring, tb ; li t3, CELL_NONE }
    { send ring, t3 }
    { send ring, r0 ; j main }
visit_full:
    { li dneed, 1 + LEN_VISIT ; li dret, visit_send }
    j drain

# the first visit carries the ray record (t4 = room)
visit_first:
    { fsel tb, t3, tcur, lexit ; slti t2, t4, 1 + LEN_VISIT_FIRST }
    { li t1, HDR_VISIT_FIRST ; bnez t2, first_full }
first_send:
    { send ring, t1 ; st kny, [sp + (S_KB + 1)] }
    { send ring, slot ; st knz, [sp + (S_KB + 2)] }
    { send ring, vw ; st addr, [sp + S_ADDR] }
    { send ring, tb ; st tcur, [sp + S_TCUR] }
    { ld t1, [sp + 0] ; st r0, [sp + S_FIRST] }
.rept 6                                             # the ray record, words 1..12: t1 and t2
    { ld t2, [sp + (2 * \+ + 1)] ; send ring, t1 }   #   take turns, one loaded while the
    { ld t1, [sp + (2 * \+ + 2)] ; send ring, t2 }   #   other is sent
.endr
    { send ring, t1 ; li t3, CELL_NONE }
    { send ring, t3 }
    { send ring, r0 ; j main }
first_full:
    { li dneed, 1 + LEN_VISIT_FIRST ; li dret, first_send }
    j drain
.endif

.if HAS_SUBGRIDS
# Enter the sub-grid of a divided top voxel (vw = -(header address)). The top level is already
# stepped past it: save that (kn, address; SAVE_STEP: its crossings). The divided voxel's T_exit
# is tcur, its t_enter tprev:
#   p = o + t_enter*d; sub index = floor(clamp((p - sub_lo)*sub_inv_cell, 0, sub_res - 1))
# then the sub-grid's first voxel (LEVEL_START). Linear code, list-scheduled.
.reg hdr  = r58                         # (temporaries: none of the registers the top level's
.reg pxx  = r43                         #  state is saved from; the level's kend and ds, lexit
.reg pyy  = r44                         #  and lim are written after their last use)
.reg pzz  = r36
.reg smx  = r53                         # sub_res mx, my, mz
.reg smy  = r54
.reg smz  = r8
.reg sux  = r59                         # up
.reg suy  = r60
.reg suz  = r61
.reg fmx  = r62                         # float(sub_res - 1): the clamp bounds
.reg fmy  = r49
.reg fmz  = r35
.reg mxy  = r50                         # mx*my
.reg sox  = r32                         # o
.reg soy  = r33
.reg soz  = r34
.reg sicx = r29                         # the sub-grid's inv_cell
.reg sicy = r30
.reg sicz = r31
.reg sa1  = r48                         # iy*mx, iz*mx*my
.reg sa2  = r42
.macro SUB_BODY
    # (the header's loads first: the scheduler keeps a load behind any earlier store through
    # another base register)
    sub hdr, r0, vw
    ld smx, [hdr + SG_RES]
    ld smy, [hdr + (SG_RES + 1)]
    ld smz, [hdr + (SG_RES + 2)]
    ld llox, [hdr + SG_LO]
    ld lloy, [hdr + (SG_LO + 1)]
    ld lloz, [hdr + (SG_LO + 2)]
    ld sicx, [hdr + SG_INV_CELL]
    ld sicy, [hdr + (SG_INV_CELL + 1)]
    ld sicz, [hdr + (SG_INV_CELL + 2)]
    ld lcx, [hdr + SG_CELL]
    ld lcy, [hdr + (SG_CELL + 1)]
    ld lcz, [hdr + (SG_CELL + 2)]
    ld pxx, [sp + RAY_DX]
    ld pyy, [sp + RAY_DY]
    ld pzz, [sp + RAY_DZ]
    ld sox, [sp + RAY_OX]
    ld soy, [sp + RAY_OY]
    ld soz, [sp + RAY_OZ]
    ld sux, [sp + S_UP]
    ld suy, [sp + (S_UP + 1)]
    ld suz, [sp + (S_UP + 2)]
.if SAVE_STEP
    STEP_WORDS st, S_TOP_TT, S_TOP_NN, S_TOP_PP
    st oor, [sp + S_TOP_OOR]
.endif
    st addr, [sp + S_TOP_ADDR]
    st knx, [sp + S_TOP_KB]
    st kny, [sp + (S_TOP_KB + 1)]
    st knz, [sp + (S_TOP_KB + 2)]
    fmul pxx, tprev, pxx
    fmul pyy, tprev, pyy
    fmul pzz, tprev, pzz
    addi fmx, smx, -1
    addi fmy, smy, -1
    addi fmz, smz, -1
    fadd pxx, sox, pxx
    fadd pyy, soy, pyy
    fadd pzz, soz, pzz
    itof fmx, fmx
    itof fmy, fmy
    itof fmz, fmz
    fsub pxx, pxx, llox
    fsub pyy, pyy, lloy
    fsub pzz, pzz, lloz
    fmul pxx, pxx, sicx
    fmul pyy, pyy, sicy
    fmul pzz, pzz, sicz
    fmax pxx, pxx, r0                                     # (r0 = +0.0)
    fmin pxx, pxx, fmx
    floor pxx, pxx
    fmax pyy, pyy, r0
    fmin pyy, pyy, fmy
    floor pyy, pyy
    fmax pzz, pzz, r0
    fmin pzz, pzz, fmz
    floor pzz, pzz
    mul mxy, smx, smy                                     # mx*my
    mul sa1, pyy, smx
    mul sa2, pzz, mxy
    add knx, pxx, sux                                     # kb = index + up
    add kny, pyy, suy
    add knz, pzz, suz
    addi addr, hdr, SUB_HEADER_WORDS
    add addr, addr, pxx
    add addr, addr, sa1
    add addr, addr, sa2
    fmov lexit, tcur                                      # the divided voxel's T_exit
    flt lim, stmax, lexit
    fsel lim, lim, stmax, lexit
    # kend = up ? res + 4 : -4; the address steps st_x, st_y*mx, st_z*mx*my
    li fmx, -4
    addi fmy, smx, 4
    sel kex, sux, fmy, fmx
    addi fmy, smy, 4
    sel key, suy, fmy, fmx
    addi fmy, smz, 4
    sel kez, suz, fmy, fmx
    fmov dsx, stx
    mul dsy, sty, smx
    mul dsz, stz, mxy
    li insub, 1
    st hdr, [sp + S_SUB_HDR]
    st lexit, [sp + S_SUB_EXIT]
    st kex, [sp + S_SUB_R]
    st key, [sp + (S_SUB_R + 1)]
    st kez, [sp + (S_SUB_R + 2)]
    st dsx, [sp + S_SUB_DS]
    st dsy, [sp + (S_SUB_DS + 1)]
    st dsz, [sp + (S_SUB_DS + 2)]
    st lim, [sp + S_SUB_LIM]
    st insub, [sp + S_INSUB]
    LEVEL_START
    DISPATCH_X
.endm

sub_enter:
.sched
    SUB_BODY
.endsched
    DISPATCH

.if LOOKAHEAD
# The same from ne_x / ne_y / ne_z (a divided top voxel): the top step (its flags are not needed:
# leave_sub recomputes them) and the sub-grid's entry in one region
.sched
ne_xs:
    STEP_PAST_X
    SUB_BODY
.endsched
    DISPATCH
.sched
ne_ys:
    STEP_PAST_Y
    SUB_BODY
.endsched
    DISPATCH
.sched
ne_zs:
    STEP_PAST_Z
    SUB_BODY
.endsched
    DISPATCH
.endif
.endif

# ---------------------------------------------------------------------------------------------
# NEXT (slot): IC found no hit in the leaf(s). Reload the ray and its place (SAVE_STEP: its
# crossings too, else recomputed from kn), then as after a step: the leaf check (tprev = the
# leaf's exit t; t_max, sub-grid end), the index check, the word, the dispatch.

.macro RESUME
.if SAVE_STEP
    FLAGS
    bnez t0, resume_slow
.else
    STEP_FROM_KN
    FLAGS
    fle lend, lim, tprev
    bnez lend, leaf_end
    beq knx, kex, level_out
    beq kny, key, level_out
    beq knz, kez, level_out
.endif
    ld vw, [addr]
.endm

on_next:
.sched
    slli sp, slot, SLOT_SHIFT
    addi sp, sp, SLOT_TABLE
    ld oox, [sp + S_OO]
    ld ooy, [sp + (S_OO + 1)]
    ld ooz, [sp + (S_OO + 2)]
    ld iix, [sp + S_II]
    ld iiy, [sp + (S_II + 1)]
    ld iiz, [sp + (S_II + 2)]
    ld stx, [sp + S_ST]
    ld sty, [sp + (S_ST + 1)]
    ld stz, [sp + (S_ST + 2)]
    ld stmax, [sp + S_STMAX]
    ld knx, [sp + S_KB]
    ld kny, [sp + (S_KB + 1)]
    ld knz, [sp + (S_KB + 2)]
    ld addr, [sp + S_ADDR]
    ld tprev, [sp + S_TCUR]
.if SAVE_STEP
    STEP_WORDS ld, S_TT, S_NN, S_PP
    ld t0, [sp + S_CODE]
.else
    ld tcur, [sp + S_TCUR]                  # (the unchanged kernel's reads: the serial mode's trace)
.endif
    ld insub, [sp + S_INSUB]
.if HAS_SUBGRIDS
    bnez insub, next_sub
.endif
    TOP_LEVEL_OPS
    fmov lexit, finf
    fmov lim, stmax
    RESUME
    DISPATCH_X
.endsched
    DISPATCH
.if HAS_SUBGRIDS
next_sub:
.sched
    ld t1, [sp + S_SUB_HDR]
    ld lexit, [sp + S_SUB_EXIT]
    ld lim, [sp + S_SUB_LIM]
    ld kex, [sp + S_SUB_R]
    ld key, [sp + (S_SUB_R + 1)]
    ld kez, [sp + (S_SUB_R + 2)]
    ld llox, [t1 + SG_LO]
    ld lloy, [t1 + (SG_LO + 1)]
    ld lloz, [t1 + (SG_LO + 2)]
    ld lcx, [t1 + SG_CELL]
    ld lcy, [t1 + (SG_CELL + 1)]
    ld lcz, [t1 + (SG_CELL + 2)]
    ld dsx, [sp + S_SUB_DS]
    ld dsy, [sp + (S_SUB_DS + 1)]
    ld dsz, [sp + (S_SUB_DS + 2)]
    RESUME
    DISPATCH_X
.endsched
    DISPATCH
.endif
.if SAVE_STEP
resume_slow:                            # (S_CODE != 0) the leaf check, then the index check
    fle lend, lim, tprev
    bnez lend, leaf_end
    j level_out
.endif

# ---------------------------------------------------------------------------------------------
# The ray ends at OS: a surface ray left (or missed) the grid -> MISS (pixel, w); a shadow ray
# left the grid or passed t_max unoccluded -> COLOR (pixel, contribution). Free the slot.

.if LEN_MISS != LEN_COLOR
.error "ray_end checks one room for MISS and COLOR"
.endif
ray_end:
.if LOOKAHEAD
    bnez labm, la_abort                             # looking for leaf B: the ray ends, no B
.endif
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
