# IC — intersection calculation (docs/kernels.md, docs/golden.md "Intersection tests (IC)",
# docs/databases.md "IC access protocol").
#
# IC receives VISIT_FIRST / VISIT messages from OS: a slot (the ray), the ICGM address of a leaf's
# first list cell and the leaf's t_exit, then the same two words for the ray's next leaf B
# (CELL_NONE: none), which IC walks after A when the ray goes on. For every cell of the list it reads the priority P and
# the shape pointer S (ldg), then the primitive's test words from resident memory (ldr, |P| <= M)
# or through the cache (ldg, |P| > M) — the paper's rule — in ascending address order, and runs
# the golden model's test for that kind, one IEEE operation for each of golden's, in its order.
#
#   surface ray: keep the nearest t with t <= t_exit and t < best (first in list order on equal
#                t); after the list: DONE (to OS) + HIT (to SC), or NEXT.
#   shadow ray:  the first primitive with t < t_max occludes: DONE at once (no more loads).
#
# Layout of the program (in this order, each part falling into the next where it can):
#   start        constants
#   <kind>s      the kinds' includes (hit normals; the test blocks are macros, expanded below)
#   hit          DONE, the winner's hit words, P = o + t*d, normals, HIT (ic_hit.inc and the
#                kind's include)
#   accept       a test's t beat `best`: remember the winner (shadow ray: occluded)
#   list_end     leaf B's words (in leaf A): walk B; else answer OS: NEXT (write_back: the ray
#                into the slot table), or the hit; a NEXT without write-back falls into main
#   main         receive a message; VISIT_FIRST -> visit_first (ray record + per-ray setup),
#                VISIT of a ray not in the registers -> reload (from the slot table)
#   cell_loop    one list cell: P, S, resident or not, kind word, dispatch to the kind's test;
#                cell_read the same for P and S that the previous test read ahead (PRELOAD)
#   <kind>_r/_g  the kind's test-word loads (ldr / ldg: the same bundles twice), overlapped with
#                its first FP operations, then the shared rest (ic_polygon.inc, ic_sphere.inc,
#                ic_cylinder.inc, ic_cone.inc)
#   write_back, occluded, visit_first
#
# Every test leaves its result in `tres` (+inf: no counting root) and ends with the same check:
# accept if tres <= lim and tres < best, where a surface ray has lim = t_exit, best = nearest so
# far (+inf at first) and a shadow ray lim = +inf, best = t_max (then accept = occluded).
#
# The single integer unit does every load, store, send, receive and branch, so the FP units get
# the work of the same bundles: the per-axis and per-coefficient operations of a test side by
# side, three at a time, and the test's first FP operations in the bundles of its loads.
#
# The ray of the last served slot stays in registers (`cur`); another slot's VISIT reloads it
# from the slot table. VISIT_FIRST writes only pixel, info and weight there (a HIT needs them);
# the geometry and the per-ray setup follow after NEXT, while OS steps to the next leaf, and
# never for a ray that ends in its first leaf.
#
# Specialisation: each kind's test sits in .if HAS_<KIND>; HAS_TWO_SIDED adds the back-root
# logic, HAS_PATCHES the fan bookkeeping for shading normals; resident / cache code exists only
# when some record lives there (RESIDENT_M > 0 / RESIDENT_M < N_PRIMITIVES), the polygon loop
# only when some polygon is not a triangle (MAX_VERTICES > 3). The generic kernel has all of it.

.proc ic
.include "protocol.inc"

.ifndef SLOTS
.equ SLOTS, 64                  # OS's rays in flight (render passes -D SLOTS)
.endif
# LISTS_LOCAL = 1 (`build_images(lists_local=True)`): the list cells are read from IC's local
# memory (ld at IC_LISTS_BASE + the cell's ICGM address), never through the cache — the
# findings' reading `--lists local` (docs/databases.md); OS still sends ICGM addresses.
.ifndef LISTS_LOCAL
.equ LISTS_LOCAL, 0
.endif
.ifndef SERIAL_TREES
.equ SERIAL_TREES, 0            # one ray tree at a time (os.s): the paper's exact load stream
.endif
# Two ways to read less or earlier than golden's access stream (docs/kernels.md, "Reading ahead,
# reading less"); both off in serial mode, whose loads are the paper's stream load by load
# (-D PRELOAD=0 -D LAZY_WORDS=0 gives that order with several rays in flight too):
# PRELOAD = 1: a sphere (ICGM) or cylinder test reads the next cell's P and S while its FP chain
#   runs (READ_AHEAD); the last cell reads its own again, an occluded shadow ray one cell more.
# LAZY_WORDS = 1: words a test's rejections do not use are read only when it goes on: the
#   cylinder's L, a quadrilateral's v1..v3, a triangle's normal (without patches).
.ifndef PRELOAD
.equ PRELOAD, !SERIAL_TREES
.endif
.ifndef LAZY_WORDS
.equ LAZY_WORDS, !SERIAL_TREES
.endif
# The generic kernel (every HAS_* = 1, `render --generic`) assembles every path, also those that
# depend on the scene's numbers rather than its features.
.equ GENERIC, HAS_POLYGONS && HAS_PATCHES && HAS_SPHERES && HAS_CYLINDERS && HAS_CONES && HAS_TWO_SIDED && HAS_REFLECTION && HAS_REFRACTION
.equ HAS_RESIDENT, RESIDENT_M > 0 || GENERIC          # some record is resident: ldr code
.equ HAS_GLOBAL, RESIDENT_M < N_PRIMITIVES || GENERIC # some record is in ICGM: ldg code
.equ HAS_NGONS, MAX_VERTICES > 3 || GENERIC           # polygons other than triangles: the loop
.equ QUADS, MAX_VERTICES == 4 && !HAS_PATCHES && !HAS_TWO_SIDED && !GENERIC  # ... or quads only
.equ N_KINDS, HAS_POLYGONS + HAS_SPHERES + HAS_CYLINDERS + HAS_CONES

# Slot table entry (SLOT_WORDS words per slot, the table at local address 0): the ray record as
# it came (RAY_* offsets of protocol.inc), then IC's per-ray setup.
.equ SLOT_SHIFT, 5
.equ SLOT_WORDS, 1 << SLOT_SHIFT
.equ SLOT_SCALE, SLOT_WORDS     # main: slot << SLOT_SHIFT as slot * 2^SLOT_SHIFT on an FP unit
.equ SLOT_SHADOW, RAY_WORDS     # 1: shadow ray (kind 3)
.equ SLOT_SX, RAY_WORDS + 1     # shear d[kx]/d[kz]
.equ SLOT_SY, RAY_WORDS + 2     # shear d[ky]/d[kz]
.equ SLOT_FX1, RAY_WORDS + 3    # permutation flags (integers 0/1): kx == 1, kx == 2,
.equ SLOT_FX2, RAY_WORDS + 4    #   ky == 1, ky == 2, kz == 1, kz == 2
.equ SLOT_FY1, RAY_WORDS + 5
.equ SLOT_FY2, RAY_WORDS + 6
.equ SLOT_FZ1, RAY_WORDS + 7
.equ SLOT_FZ2, RAY_WORDS + 8
.if SLOT_FZ2 >= SLOT_WORDS
.error "slot table entry overflows SLOT_WORDS"
.endif

# Fan buffers (patches): per polygon test, E0_i at 3i, E1_(i-1) at 3i+1, the running winding
# after fan triangle i-2 at 3i+2 — what the HIT needs to find the hit's fan triangle j and its
# barycentrics without reading the vertices again.
.if MAX_VERTICES > 3
.equ FAN_WORDS, 3 * MAX_VERTICES
.else
.equ FAN_WORDS, 9
.endif

# ---- registers -------------------------------------------------------------------------------
# constants
.reg one    = r1                # integer 1
.reg two    = r2                # integer 2
.reg pinf   = r3                # +inf
.reg mlim   = r4                # 2M + 1: (P + M) <u 2M + 1  <=>  -M <= P <= M  <=>  |P| <= M
.reg hvf    = r5                # the VISIT_FIRST header
# the ray of slot `cur`, kept in registers between visits
.reg ox     = r6
.reg oy     = r7
.reg oz     = r8
.reg dx     = r9
.reg dy     = r10
.reg dz     = r11
.reg tmin   = r12
.reg tmax   = r13
.reg shadow = r14               # 1: shadow ray
.reg sx     = r15               # polygon test shears and axis permutation (per-ray setup)
.reg sy     = r16
.reg fx1    = r17
.reg fx2    = r18
.reg fy1    = r19
.reg fy2    = r20
.reg fz1    = r21
.reg fz2    = r22
# messages
.reg cur    = r23               # slot whose ray is in the registers above (-1: none)
.reg slot   = r24               # slot of the message being served
.reg dirty  = r25               # 1: the slot table lacks cur's geometry and setup (first visit)
# the visit
.reg cell   = r26               # current list cell (ICGM address)
.reg lim    = r27               # surface: t_exit; shadow: +inf
.reg best   = r28               # surface: nearest t so far (+inf); shadow: t_max
.reg pri    = r29               # P of the cell (negative: last cell)
.reg shp    = r30               # S: shape record address
.reg kw     = r31               # the record's kind/flags word
# the winner (surface rays): its cell's P and S, its kind word (PRELOAD: kept in `winner`
# during the list, loaded here by the hit)
.reg wpri   = r32
.reg wshp   = r33
.reg wkw    = r34
# PRELOAD, during a list: the next cell's P and S as a test read them ahead, and the address it
# read them from (the test's own cell when it is the last: a word already loaded)
.reg npri   = r32
.reg nshp   = r33
.reg padr   = r34
# fan buffers (HAS_PATCHES): the current test's and the winner's
.reg cbuf   = r35
.reg wbuf   = r36
# every test's result
.reg tres   = r37
# r38..r62: temporaries, named per test in the includes
# the hit (ic_hit.inc): r38..r48 the kinds' normal code, r49..r51 hit_head's
.reg h_hdr  = r49
.reg h_sb   = r50
.reg h_w    = r51
.reg hlum   = r52               # luminance pointer
.reg hid    = r53               # primitive id
.reg hpx    = r54               # P = o + t*d
.reg hpy    = r55
.reg hpz    = r56
.reg ngx    = r57               # geometric normal
.reg ngy    = r58
.reg ngz    = r59
.reg nsx    = r60               # shading normal
.reg nsy    = r61
.reg nsz    = r62
.reg ch_bx  = r38               # cylinder / cone normal: w = P - B, then u
.reg ch_by  = r39
.reg ch_bz  = r40
.reg ch_ax  = r41               # axis a
.reg ch_ay  = r42
.reg ch_az  = r43
.reg ch_wa  = r44               # dot(w, a)
.reg ch_px  = r45               # products
.reg ch_py  = r46
.reg ch_pz  = r47
.reg ch_l   = r48               # |u|

# ---- macros: the code that reads a record comes in twins, one per memory ------------------------
# A shape record is read from resident memory (`ldr`) or from ICGM through the cache (`ldg`) by
# the paper's priority rule, so every block that reads one is written once, as a macro of the
# label suffix m (r / g) and the load ld (ldr / ldg), and expanded once per memory the scene uses.
# TWINS expands BLOCK for the global memory, then (jumping over it to `shared`) for resident
# memory: `TWINS SPH_LOAD, sph_test` gives sph_g, then sph_r, falling into sph_test.
.macro TWINS block, shared
.if HAS_GLOBAL
    \block g, ldg
.if HAS_RESIDENT
    j \shared
.endif
.endif
.if HAS_RESIDENT
    \block r, ldr
.endif
.endm

# The kind dispatch: `kind` = `word` & KIND_MASK (polygon 0, sphere 1, cylinder 2, cone 3), then a
# jump to poly_<to>, sph_<to>, cyl_<to> or cone_<to> (only the kinds the scene has).
.macro KIND_JUMP kind, word, to
.if N_KINDS > 1
    { andi \kind, \word, KIND_MASK }
.endif
.if HAS_POLYGONS && N_KINDS > 1
    beqz \kind, poly_\to
.endif
.if HAS_SPHERES && (HAS_CYLINDERS || HAS_CONES)
    beq \kind, one, sph_\to
.endif
.if HAS_CYLINDERS && HAS_CONES
    beq \kind, two, cyl_\to
.endif
.if HAS_CONES
    j cone_\to
.elif HAS_CYLINDERS
    j cyl_\to
.elif HAS_SPHERES
    j sph_\to
.else
    j poly_\to
.endif
.endm

# The first hit words of a cylinder or cone (B, a), `ld` from the winner's memory, with w = P - B
# and its first two products with a on their way (axis_normal, ic_hit.inc, goes on from there).
.macro AXIS_HIT_LOAD ld, base, axis
    { \ld ch_bx, [wshp + \base] }
    { \ld ch_by, [wshp + (\base + 1)] ; fsub ch_bx, hpx, ch_bx }
    { \ld ch_bz, [wshp + (\base + 2)] ; fsub ch_by, hpy, ch_by }
    { \ld ch_ax, [wshp + \axis]     ; fsub ch_bz, hpz, ch_bz }
    { \ld ch_ay, [wshp + (\axis + 1)] ; fmul ch_px, ch_bx, ch_ax }
    { \ld ch_az, [wshp + (\axis + 2)] ; fmul ch_py, ch_by, ch_ay }
.endm

.data
slot_table: .space SLOTS * SLOT_WORDS   # slot s at slot_table + (s << SLOT_SHIFT)
.if PRELOAD
winner:     .space 3                    # the winner's P, S and kind word (accept)
.endif
.if HAS_PATCHES
fan_a:      .space FAN_WORDS
fan_b:      .space FAN_WORDS
.endif

# Every memory's copy of a block with nothing between them (each copy ends in branches):
# `BOTH SPH_BLOCK` gives sph_g, then sph_r.
.macro BOTH block
.if HAS_GLOBAL
    \block g, ldg, 1
.endif
.if HAS_RESIDENT
    \block r, ldr, 0
.endif
.endm

# PRELOAD: a test reads the next cell's P and S ahead (after its own words: the load stream keeps
# cell order) from padr = more ? cell : the test's own cell (the last cell: a word just read);
# `more` is the flag P >= 0 (fle r0, pri), `cell` has been advanced (padr held the test's own
# cell). Then padr = P + M for cell_read's memory choice. A test that reads ahead (`ahead` = 1)
# ends in to_cell1 / to_next1 / to_accept1 (cell_read, next_read, accept_read), one that does not
# in to_cell0 / to_next0 / to_accept0 (cell_loop, next_cell, accept).
# A list cell's P and S at `base` (from ICGM; LISTS_LOCAL: from IC's local copy), one load each.
.macro READ_CELL base, p, s
.if LISTS_LOCAL
    ld \p, [\base + (IC_LISTS_BASE + CELL_PRIORITY)]
    ld \s, [\base + (IC_LISTS_BASE + CELL_SHAPE)]
.else
    ldg \p, [\base + CELL_PRIORITY]
    ldg \s, [\base + CELL_SHAPE]
.endif
.endm
.macro READ_AHEAD more, ahead
.if PRELOAD && \ahead
    fsel padr, \more, cell, padr
    READ_CELL padr, npri, nshp
.if HAS_RESIDENT && HAS_GLOBAL
    addi padr, npri, RESIDENT_M
.endif
.endif
.endm

# The cell's kind dispatch (`m_t` = kind): a branch to every kind's block but the first kind's,
# which follows. Kinds: polygon 0, sphere 1, cylinder 2, cone 3.
# A reload (another slot's ray) loads the polygon setup (shears, axis flags) only when a polygon
# test needs it (poly_<m>) if the scene has other kinds too: sx = +inf (never a real shear: |sx| <= 1)
# marks it as not loaded.
.equ LAZY_SETUP, HAS_POLYGONS && (HAS_SPHERES || HAS_CYLINDERS || HAS_CONES)
.equ FIRST_CYL, HAS_CYLINDERS
# Without two-sided primitives and patches (and without cones) a kind word is the kind itself
# for every kind but the polygon (its vertex count, >= 3, sits from bit 8): DISPATCH compares the
# word with 1 and 2 at once, without the `andi`.
.equ EXACT_KW, N_KINDS > 1 && !HAS_TWO_SIDED && !HAS_PATCHES && !HAS_CONES
.equ FIRST_SPH, HAS_SPHERES && !HAS_CYLINDERS
.equ FIRST_POLY, HAS_POLYGONS && !HAS_SPHERES && !HAS_CYLINDERS
.equ FIRST_CONE, HAS_CONES && !HAS_POLYGONS && !HAS_SPHERES && !HAS_CYLINDERS
.macro DISPATCH m
.if EXACT_KW
.if HAS_SPHERES && FIRST_CYL
    beq kw, one, sph_\m
.endif
.if HAS_POLYGONS && FIRST_CYL
    bne kw, two, poly_\m
.elif HAS_POLYGONS && FIRST_SPH
    bne kw, one, poly_\m
.endif
.else
.if N_KINDS > 1
    { andi m_t, kw, KIND_MASK }
.endif
.if HAS_POLYGONS && !FIRST_POLY
    beqz m_t, poly_\m
.endif
.if HAS_SPHERES && !FIRST_SPH
    beq m_t, one, sph_\m
.endif
.if HAS_CONES && FIRST_CYL
    bne m_t, two, cone_\m                                               # kind 2 or 3 left
.elif HAS_CONES && FIRST_SPH
    bne m_t, one, cone_\m                                               # kind 1 or 3 left
.elif HAS_CONES && FIRST_POLY
    bnez m_t, cone_\m
.endif
.endif
.endm

# The end of every test's cheap part: `go` = the test failed and another cell follows, so the
# next cell starts at once (one taken branch instead of two). `more` = P >= 0 comes from an FP
# compare of P's raw word: a non-negative integer is a non-negative (denormal or zero) float, a
# negative one has its sign bit set (a negative float or a NaN: fle gives 0), in fp32 and fp64.
# A test forms go = flt(thr, -disc) with thr = more ? +0 : +inf, i.e. more && disc < 0 (NaN: no),
# where -disc is computed beside disc as the reversed subtraction (exactly -disc, also for 0).

# The early rejection (sphere, cylinder): the golden test computes q = v - s*u (the closest point
# of the line) and disc = r2 - q.q after the division s = v.u / u.u (cylinder) or the product
# s*u (sphere). Exactly, q.q * u.u = v.v * u.u - (v.u)^2, which needs neither: a test forms
# E = v.v * u.u * EARLY_K - (v.u)^2 from the very words golden sums (v.u as golden rounds it) and
# goes to the next cell at once when E > r2 * u.u (the sphere: u.u = d.d = 1, E > r2). The
# factor EARLY_K = 1 - 2^-12 is a margin of 4096 rounding units of fp32 (2^43 of fp64): both
# sides' rounding errors are below 50 units of v.v * u.u (docs/kernels.md, "Early rejection"),
# so a rejected test is one golden finds no real root for (disc < 0), and the outcome, the
# loads and the counts are unchanged; only the cycles differ. Guards keep the error bounds
# relative: u.u and v.v at least EARLY_LO (no denormals on the way), v.v below EARLY_HI (no
# overflow); outside them the test runs golden's chain only.
.equ EARLY_K, 0.999755859375    # 1 - 2^-12, exact in fp32 and fp64
# The cylinder takes the same verdict earlier from C = (w x d).a, exactly q.q * u.u for a unit
# axis: C^2 + r2 da^2 > r2 + w.w EARLY_M (r2, EARLY_LO < w.w; docs/kernels.md, "Early rejection").
.equ EARLY_M, 0.00006103515625  # 2^-14, of w.w
.equ EARLY_LO, 1e-30
.equ EARLY_HI, 1e30
# The range rejections (sphere, cylinder; docs/kernels.md, "Range rejection"): after golden's disc,
# before (or beside) its sqrt, a test whose roots are all out of range (t <= t_min, t beyond
# L = min(t_exit, best), the cylinder's z outside [0, L]) goes to the next cell. Each bound is
# exact or compares squares with a relative margin far above the rounding between them: disc
# (1 -+ 2^-18) (RANGE_LOW, RANGE_K) against h^2, L' = L (1 + 2^-20) > L; the cylinder's z, whose
# rounding is absolute, by RANGE_M (2^-12) of its terms' size.
.equ RANGE_M, 0.000244140625    # 2^-12
.equ RANGE_L, 1.00000095367431640625  # 1 + 2^-20, exact in fp32 and fp64
.equ RANGE_K, 1.000003814697265625    # 1 + 2^-18
.equ RANGE_LOW, 0.999996185302734375  # 1 - 2^-18
.equ RANGE_Z, 1.0009765625      # 1 + 2^-10 (the cylinder's far side)

# ---- start -----------------------------------------------------------------------------------
.text
start:
    { li one, 1 ; lf pinf, inf }
    { li two, 2 }
    { li mlim, 2 * RESIDENT_M + 1 }
    { li hvf, HDR_VISIT_FIRST }
.if HAS_PATCHES
    { li cbuf, fan_a }
.endif
    { li cur, -1 }
    j main

# main's registers (the message, the slot, the per-ray setup)
.reg m_hdr = r38
.reg m_sb  = r39                # slot << SLOT_SHIFT
.reg m_t   = r40
.reg m_ax  = r41                # per-ray setup temporaries
.reg m_ay  = r42
.reg m_az  = r43
.reg m_cxy = r44
.reg m_cxz = r45
.reg m_cyz = r46
.reg m_kz0 = r47
.reg m_dkz = r50
.reg m_neg = r51
.reg m_dkx = r52
.reg m_dky = r53
.reg m_ncyz = r54
.reg m_u   = r55
.reg m_v   = r56
.reg m_texit = r57
# ---- the tests ------------------------------------------------------------------------------------
.if HAS_POLYGONS
.include "ic_polygon.inc"
.endif
.if HAS_SPHERES
.include "ic_sphere.inc"
.endif
.if HAS_CYLINDERS
.include "ic_cylinder.inc"
.endif
.if HAS_CONES
.include "ic_cone.inc"
.endif

# ---- the hit --------------------------------------------------------------------------------------
# The end of leaf B (list_end; m_t = best < inf): a surface ray's hit (falls into `hit`), else NEXT.
list_end_b:
    { bnez shadow, send_next }
    beqz m_t, send_next
.include "ic_hit.inc"

# A ray's geometry and kind from its registers to its slot-table entry (m_sb = slot <<
# SLOT_SHIFT), one word a bundle: write_back stores them (`op` = st); reload loads the same words
# in its own order.
.macro SLOT_RAY op
    { \op ox, [m_sb + (slot_table + RAY_OX)] }
    { \op oy, [m_sb + (slot_table + RAY_OY)] }
    { \op oz, [m_sb + (slot_table + RAY_OZ)] }
    { \op dx, [m_sb + (slot_table + RAY_DX)] }
    { \op dy, [m_sb + (slot_table + RAY_DY)] }
    { \op dz, [m_sb + (slot_table + RAY_DZ)] }
    { \op tmin, [m_sb + (slot_table + RAY_TMIN)] }
    { \op tmax, [m_sb + (slot_table + RAY_TMAX)] }
    { \op shadow, [m_sb + (slot_table + SLOT_SHADOW)] }
.endm
# ... and the rest of its polygon setup: the axis flags after fx1.
.macro SLOT_AXES op
    { \op fx2, [m_sb + (slot_table + SLOT_FX2)] }
    { \op fy1, [m_sb + (slot_table + SLOT_FY1)] }
    { \op fy2, [m_sb + (slot_table + SLOT_FY2)] }
    { \op fz1, [m_sb + (slot_table + SLOT_FZ1)] }
    { \op fz2, [m_sb + (slot_table + SLOT_FZ2)] }
.endm
# A test's result beat `best` (the check ends every test): a shadow ray is occluded; a surface
# ray remembers the winner (its kind word stays in a register: word 0 is never read again).
# With PRELOAD the winner goes to `winner` (its registers hold the next cell's P, S and padr).
.macro ACCEPT
.if PRELOAD
    { bnez shadow, occluded ; fmov best, tres }
    { st pri, [winner] }
    { st shp, [winner + 1] }
.if HAS_PATCHES
    { st kw, [winner + 2] ; fmov wbuf, cbuf }
    { xori cbuf, cbuf, fan_a ^ fan_b }
.else
    { st kw, [winner + 2] }
.endif
.else
    { bnez shadow, occluded ; fmov best, tres ; fmov wpri, pri ; fmov wshp, shp }
.if HAS_PATCHES
    { fmov wkw, kw ; fmov wbuf, cbuf ; xori cbuf, cbuf, fan_a ^ fan_b }   # the winner's fan data
.else                                                                   #   stays, the next test
    { fmov wkw, kw }                                                    #   writes the other buffer
.endif
.endif
.endm
.if PRELOAD
accept_read:                    # ... after a test that read the next cell ahead
to_accept1:
    ACCEPT
next_read:
to_next1:
    bge pri, r0, cell_read      # P > 0: not the last cell
    j list_end
.endif
accept:
to_accept0:
.if !PRELOAD
accept_read:
to_accept1:
.endif
    ACCEPT
next_cell:
to_next0:
.if !PRELOAD
next_read:
to_next1:
.endif
    bge pri, r0, cell_loop      # P > 0: not the last cell

# ---- the list is done: answer OS, or walk the message's second leaf ----------------------------
# A VISIT / VISIT_FIRST ends with a second leaf B (cell_B, t_exit_B; cell_B = CELL_NONE: none).
# While leaf A is walked those two words still wait in the ring FIFO, and cur = slot; once they
# are read cur = hvf (the VISIT_FIRST header: never a slot, also in the low 32 bits that integer
# compares see in fp64) until the answer (send_next, hit, occluded put cur = slot
# back). So list_end reads them in leaf A (every surface ray's answer comes through here), and
# `occluded` (a shadow ray's, from accept) reads them when cur = slot.
list_end:
    { bne cur, slot, list_end_b ; flt m_t, best, pinf }                # B walked: the words are read
    recv cell, ring                                                     # cell_B
    { recv m_texit, ring ; fsel m_t, shadow, r0, m_t ; fmov cur, hvf }  # t_exit_B; m_t = a hit
    { bnez m_t, hit ; fsel lim, shadow, pinf, m_texit }                 # (lim, best: as main)
    { bge cell, r0, visit ; fsel best, shadow, tmax, pinf }             # leaf B: walk it now
send_next:
    { li m_t, HDR_NEXT ; lf m_sb, SLOT_SCALE ; fmov cur, slot }
    { send ring, m_t ; fmul m_sb, slot, m_sb }                          # (main: slot << SLOT_SHIFT)
    { send ring, slot }
    bnez dirty, write_back      # (a ray's first visit; else on to the next message)
# ---- main: one message from OS ----------------------------------------------------------------
# The slot's table offset m_sb = slot << SLOT_SHIFT is formed on an FP unit while the message
# arrives (the integer unit is busy receiving): a slot number is a denormal float, and multiplying
# it by 2^SLOT_SHIFT is exact (it stays below 2^23), in fp32 and fp64.
main:
    recv m_hdr, ring
    recv slot, ring
    { recv cell, ring ; lf m_sb, SLOT_SCALE }                           # the leaf's first cell
    { recv m_texit, ring ; fmul m_sb, slot, m_sb }                      # slot << SLOT_SHIFT
    beq m_hdr, hvf, visit_first
    { beq slot, cur, visit ; fsel lim, shadow, pinf, m_texit ; fsel best, shadow, tmax, pinf }
# VISIT of a ray that is not in the registers: load it from the slot table, its kind and t_max
# first, so that lim and best are chosen in the bundles of the other loads.
reload:
    { ld shadow, [m_sb + (slot_table + SLOT_SHADOW)] ; fmov cur, slot }
    { ld tmax, [m_sb + (slot_table + RAY_TMAX)] }
    { ld ox, [m_sb + (slot_table + RAY_OX)] ; fsel lim, shadow, pinf, m_texit }
.if LAZY_SETUP
    { ld oy, [m_sb + (slot_table + RAY_OY)] ; fsel best, shadow, tmax, pinf ; fmov sx, pinf }
.else
    { ld oy, [m_sb + (slot_table + RAY_OY)] ; fsel best, shadow, tmax, pinf }
.endif
    { ld oz, [m_sb + (slot_table + RAY_OZ)] }
    { ld dx, [m_sb + (slot_table + RAY_DX)] }
    { ld dy, [m_sb + (slot_table + RAY_DY)] }
    { ld dz, [m_sb + (slot_table + RAY_DZ)] }
    { ld tmin, [m_sb + (slot_table + RAY_TMIN)] }
.if HAS_POLYGONS && !LAZY_SETUP
    { ld sx, [m_sb + (slot_table + SLOT_SX)] }
    { ld sy, [m_sb + (slot_table + SLOT_SY)] }
    { ld fx1, [m_sb + (slot_table + SLOT_FX1)] }
    SLOT_AXES ld
.endif
                                                                        # (falls into visit)
# ---- the list ----------------------------------------------------------------------------------
# One cell: P and S (ldg, in that order), the memory by the priority rule, the kind word, the kind
# dispatch (DISPATCH), the kind's test. ICGM, the more common memory, falls through; so does the
# scene's first kind (FIRST_*: cylinders, else spheres, else polygons, else cones), so a cell of
# that kind in ICGM pays no taken branch before its test. Every test is expanded twice, one copy
# per memory (BOTH), so no copy jumps to shared code.
visit:
cell_loop:
to_cell0:
.if PRELOAD                         # (the list's first cell, or after a test that read no cell
    READ_CELL cell, npri, nshp      #  ahead: P and S as a test reads them ahead)
.if HAS_RESIDENT && HAS_GLOBAL
    { addi padr, npri, RESIDENT_M }
.endif
cell_read:                          # P and S read ahead (padr: P + M)
to_cell1:
.if HAS_RESIDENT && HAS_GLOBAL
    { bltu padr, mlim, rec_r ; fmov shp, nshp }                         # |P| <= M: resident
.else
    { fmov shp, nshp }
.endif
.else
cell_read:
to_cell1:
    READ_CELL cell, pri, shp
.if HAS_RESIDENT && HAS_GLOBAL
    { addi m_t, pri, RESIDENT_M }
    { bltu m_t, mlim, rec_r }                                           # |P| <= M: resident
.endif
.endif
.macro RECORD m, ld, slow                # slow: 1 for ICGM (a load holds issue t_c = 2 cycles)
rec_\m:
.if PRELOAD
    { \ld kw, [shp + REC_KIND] ; fmov pri, npri ; fmov padr, cell }
.else
    { \ld kw, [shp + REC_KIND] }
.endif
    DISPATCH \m
.if FIRST_CYL
    CYL_BLOCK \m, \ld, \slow
.elif FIRST_SPH
    SPH_BLOCK \m, \ld, \slow
.elif FIRST_POLY
    POLY_BLOCK \m, \ld, \slow
.else
    CONE_BLOCK \m, \ld, \slow
.endif
.endm
.if HAS_GLOBAL
    RECORD g, ldg, 1
.endif
.if HAS_RESIDENT
    RECORD r, ldr, 0
.endif
.if HAS_POLYGONS && !FIRST_POLY
    BOTH POLY_BLOCK
.endif
.if HAS_SPHERES && !FIRST_SPH
    BOTH SPH_BLOCK
.endif
.if HAS_CYLINDERS && !FIRST_CYL
    BOTH CYL_BLOCK
.endif
.if HAS_CONES && !FIRST_CONE
    BOTH CONE_BLOCK
.endif

# The ray goes on: write its geometry and setup to the slot table while OS steps to the next leaf.
write_back:
    SLOT_RAY st
.if HAS_POLYGONS
    { st sx, [m_sb + (slot_table + SLOT_SX)] }
    { st sy, [m_sb + (slot_table + SLOT_SY)] }
    { st fx1, [m_sb + (slot_table + SLOT_FX1)] }
    SLOT_AXES st
.endif
    { fmov dirty, r0 ; j main }

# An occluded shadow ray ends here.
# In leaf A (cur = slot) the message's last two words (leaf B) are read first.
occluded:
    { li m_t, HDR_DONE ; fmov dirty, r0 }
    { bne cur, slot, occluded_send ; fmov cur, slot }
    recv m_hdr, ring                                                    # cell_B
    recv m_hdr, ring                                                    # t_exit_B
occluded_send:
    { send ring, m_t }
    { send ring, slot }
    j main
# VISIT_FIRST: the 13-word ray record follows. Pixel, info and weight go straight to the slot
# table (only a HIT needs them); origin, direction, t_min, t_max stay in registers and reach the
# table only if the ray needs another visit (write_back, after NEXT). Meanwhile the FP units do
# golden's `ic_rays` setup: kz = axis of the largest |d| (ties x, y, z), kx = kz+1, ky = kx+1
# (mod 3), kx <-> ky if d[kz] < 0; sx = d[kx]/d[kz], sy = d[ky]/d[kz]. The axes become 0/1 flags
# (fz1 = [kz == 1], ...) for the polygon test's fsel permutation A[k] = f2 ? Az : (f1 ? Ay : Ax).
# Unswapped: kz = 0 -> (kx, ky) = (1, 2); kz = 1 -> (2, 0); kz = 2 -> (0, 1).
visit_first:                    # (m_sb: main)
    recv m_t, ring
    { st m_t, [m_sb + (slot_table + RAY_PIXEL)] }
    recv m_t, ring
    { st m_t, [m_sb + (slot_table + RAY_INFO)] }
    { andi m_t, m_t, 3 }
    { slt shadow, two, m_t }                        # kind 3
    recv ox, ring
    recv oy, ring
    recv oz, ring
    recv dx, ring
.if HAS_POLYGONS
    { recv dy, ring ; fabs m_ax, dx }
    { recv dz, ring ; fabs m_ay, dy }
    { recv tmin, ring ; fabs m_az, dz ; fle m_cxy, m_ay, m_ax }          # |dx| >= |dy|
    { recv tmax, ring ; fle m_cxz, m_az, m_ax ; fle m_cyz, m_az, m_ay }  # |dx| >= |dz|, |dy| >= |dz|
    { recv m_t, ring ; fsel m_kz0, m_cxy, m_cxz, r0 ; fsel m_ncyz, m_cyz, r0, one }
    { st m_t, [m_sb + (slot_table + RAY_WR)] ; fsel fz1, m_kz0, r0, m_cyz ; fsel fz2, m_kz0, r0, m_ncyz }
    { recv m_t, ring ; fsel m_u, fz1, dy, dx }
    { st m_t, [m_sb + (slot_table + RAY_WG)] ; fsel m_dkz, fz2, dz, m_u }                # d[kz]
    { recv m_t, ring ; flt m_neg, m_dkz, r0 }       # d[kz] < 0: swap kx, ky
    { st m_t, [m_sb + (slot_table + RAY_WB)] ; fsel fx1, m_neg, fz2, m_kz0 ; fsel fx2, m_neg, m_kz0, fz1 ; fsel fy1, m_neg, m_kz0, fz2 }
    { li dirty, 1 ; fsel fy2, m_neg, fz1, m_kz0 ; fsel m_u, fx1, dy, dx }
    { fsel m_v, fy1, dy, dx ; fsel m_dkx, fx2, dz, m_u }                 # d[kx]
    { mov cur, slot ; fsel m_dky, fy2, dz, m_v ; fdiv sx, m_dkx, m_dkz }  # d[ky]; sx
    { fdiv sy, m_dky, m_dkz ; fsel lim, shadow, pinf, m_texit }         # (two FP units left)
    { fsel best, shadow, tmax, pinf ; j visit }
.else
    recv dy, ring
    recv dz, ring
    recv tmin, ring
    recv tmax, ring
    recv m_t, ring
    { st m_t, [m_sb + (slot_table + RAY_WR)] }
    recv m_t, ring
    { st m_t, [m_sb + (slot_table + RAY_WG)] }
    recv m_t, ring
    { st m_t, [m_sb + (slot_table + RAY_WB)] ; fsel lim, shadow, pinf, m_texit ; fsel best, shadow, tmax, pinf }
    { li dirty, 1 }
    { mov cur, slot }
    j visit
.endif
