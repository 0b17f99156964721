# IC — intersection calculation (docs/kernels.md, docs/golden.md "Intersection tests (IC)",
# docs/databases.md "IC access protocol").
#
# IC receives VISIT_FIRST / VISIT messages from OS: a slot (the ray), the ICGM address of a leaf's
# first list cell and the leaf's t_exit. For every cell of the list it reads the priority P and
# the shape pointer S (ldg), then the primitive's test words from resident memory (ldr, |P| <= M)
# or through the cache (ldg, |P| > M) — the paper's rule — in ascending address order, and runs
# the golden model's test for that kind, one IEEE operation for each of golden's, in its order.
#
#   surface ray: keep the nearest t with t <= t_exit and t < best (first in list order on equal
#                t); after the list: DONE (to OS) + HIT (to SC), or NEXT.
#   shadow ray:  the first primitive with t < t_max occludes: DONE at once (no more loads).
#
# Layout of the program:
#   start        constants
#   main         receive a message; VISIT_FIRST -> visit_first (ray record + per-ray setup),
#                VISIT of a ray not in the registers -> reload (from the slot table)
#   cell_loop    one list cell: P, S, resident or not, kind word, dispatch to the kind's test
#   <kind>_r/_g  the kind's test-word loads (ldr / ldg: the same bundles twice), overlapped with
#                its first FP operations, then the shared rest (ic_polygon.inc, ic_sphere.inc,
#                ic_cylinder.inc, ic_cone.inc)
#   accept       a test's t beat `best`: remember the winner (shadow ray: occluded)
#   list_end     answer OS: NEXT (write_back: the ray into the slot table), or the hit
#   hit          DONE, the winner's hit words, P = o + t*d, normals, HIT (ic_hit.inc and the
#                kind's include)
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
# The generic kernel (every HAS_* = 1, `render --generic`) assembles every path, also those that
# depend on the scene's numbers rather than its features.
.equ GENERIC, HAS_POLYGONS && HAS_PATCHES && HAS_SPHERES && HAS_CYLINDERS && HAS_CONES && HAS_TWO_SIDED && HAS_REFLECTION && HAS_REFRACTION
.equ HAS_RESIDENT, RESIDENT_M > 0 || GENERIC          # some record is resident: ldr code
.equ HAS_GLOBAL, RESIDENT_M < N_PRIMITIVES || GENERIC # some record is in ICGM: ldg code
.equ HAS_NGONS, MAX_VERTICES > 3 || GENERIC           # polygons other than triangles: the loop
.equ N_KINDS, HAS_POLYGONS + HAS_SPHERES + HAS_CYLINDERS + HAS_CONES

# Slot table entry (SLOT_WORDS words per slot, the table at local address 0): the ray record as
# it came (RAY_* offsets of protocol.inc), then IC's per-ray setup.
.equ SLOT_SHIFT, 5
.equ SLOT_WORDS, 1 << SLOT_SHIFT
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
# the winner (surface rays): its cell's P and S, its kind word
.reg wpri   = r32
.reg wshp   = r33
.reg wkw    = r34
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
.if HAS_PATCHES
fan_a:      .space FAN_WORDS
fan_b:      .space FAN_WORDS
.endif

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

# ---- main: one message from OS ---------------------------------------------------------------
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
main:
    recv m_hdr, ring
    recv slot, ring
    recv cell, ring             # the leaf's first cell
    recv m_texit, ring
    beq m_hdr, hvf, visit_first
    { beq slot, cur, visit ; fsel lim, shadow, pinf, m_texit ; fsel best, shadow, tmax, pinf }

# A ray's geometry and kind between its registers and its slot-table entry (m_sb = slot <<
# SLOT_SHIFT): `op` is ld (reload) or st (write_back), one word a bundle.
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

# VISIT of a ray that is not in the registers: load it from the slot table.
reload:
    { slli m_sb, slot, SLOT_SHIFT }
    SLOT_RAY ld
.if HAS_POLYGONS
    { ld sx, [m_sb + (slot_table + SLOT_SX)] }
    { ld sy, [m_sb + (slot_table + SLOT_SY)] ; fsel best, shadow, tmax, pinf }
    { ld fx1, [m_sb + (slot_table + SLOT_FX1)] ; fsel lim, shadow, pinf, m_texit }
    SLOT_AXES ld
.else
    { fsel best, shadow, tmax, pinf ; fsel lim, shadow, pinf, m_texit }
.endif
    { fmov cur, slot ; j visit }

# VISIT_FIRST: the 13-word ray record follows. Pixel, info and weight go straight to the slot
# table (only a HIT needs them); origin, direction, t_min, t_max stay in registers and reach the
# table only if the ray needs another visit (write_back, after NEXT). Meanwhile the FP units do
# golden's `ic_rays` setup: kz = axis of the largest |d| (ties x, y, z), kx = kz+1, ky = kx+1
# (mod 3), kx <-> ky if d[kz] < 0; sx = d[kx]/d[kz], sy = d[ky]/d[kz]. The axes become 0/1 flags
# (fz1 = [kz == 1], ...) for the polygon test's fsel permutation A[k] = f2 ? Az : (f1 ? Ay : Ax).
# Unswapped: kz = 0 -> (kx, ky) = (1, 2); kz = 1 -> (2, 0); kz = 2 -> (0, 1).
visit_first:
    { slli m_sb, slot, SLOT_SHIFT }
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
    { fdiv sy, m_dky, m_dkz ; fsel lim, shadow, pinf, m_texit ; fsel best, shadow, tmax, pinf }
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
.endif

# ---- the list ----------------------------------------------------------------------------------
visit:
cell_loop:
.if LISTS_LOCAL
    { ld pri, [cell + (IC_LISTS_BASE + CELL_PRIORITY)] }
    { ld shp, [cell + (IC_LISTS_BASE + CELL_SHAPE)] }
.else
    { ldg pri, [cell + CELL_PRIORITY] }
    { ldg shp, [cell + CELL_SHAPE] }
.endif
.if HAS_RESIDENT && HAS_GLOBAL
    { addi m_t, pri, RESIDENT_M }
    { bgeu m_t, mlim, rec_g }
.endif

# Kind dispatch (KIND_JUMP): only the kinds the scene has.
.macro REC_LOAD m, ld
rec_\m:
    { \ld kw, [shp + REC_KIND] }
    KIND_JUMP m_t, kw, \m
.endm
.if HAS_RESIDENT
    REC_LOAD r, ldr
.endif
.if HAS_GLOBAL
    REC_LOAD g, ldg
.endif

# A test's result beat `best` (the check ends every test): a shadow ray is occluded; a surface
# ray remembers the winner (its kind word stays in a register: word 0 is never read again).
accept:
    { bnez shadow, occluded ; fmov best, tres ; fmov wpri, pri ; fmov wshp, shp }
.if HAS_PATCHES
    { fmov wkw, kw ; fmov wbuf, cbuf ; xori cbuf, cbuf, fan_a ^ fan_b }   # the winner's fan data
.else                                                                   #   stays, the next test
    { fmov wkw, kw }                                                    #   writes the other buffer
.endif
next_cell:
    bge pri, r0, cell_loop      # P > 0: not the last cell

# ---- the list is done: answer OS ----------------------------------------------------------------
list_end:
    { bnez shadow, send_next ; flt m_t, best, pinf }
    bnez m_t, hit
send_next:
    { li m_t, HDR_NEXT }
    { send ring, m_t }
    { send ring, slot }
    beqz dirty, main
# The ray goes on: write its geometry and setup to the slot table while OS steps to the next leaf.
write_back:
    { slli m_sb, slot, SLOT_SHIFT }
    SLOT_RAY st
.if HAS_POLYGONS
    { st sx, [m_sb + (slot_table + SLOT_SX)] }
    { st sy, [m_sb + (slot_table + SLOT_SY)] }
    { st fx1, [m_sb + (slot_table + SLOT_FX1)] }
    SLOT_AXES st
.endif
    { fmov dirty, r0 ; j main }

# An occluded shadow ray ends here.
occluded:
    { li m_t, HDR_DONE }
    { send ring, m_t }
    { send ring, slot }
    { fmov dirty, r0 ; j main }

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
.include "ic_hit.inc"
