# kernels/sc.s — SC, the shading calculation stage of a Netsushisen PE.
#
# SC is the third stage of the OS -> IC -> SC ring (docs/kernels.md). It is stateless and serves
# three messages, in whatever order they arrive on its ring FIFO:
#
#   HIT   (from IC)  shade the hit exactly as the golden model's `_shade` does (docs/golden.md,
#                    "Shading (SC) and ray spawning"): the same IEEE operations in the same
#                    order, so every spawned ray is bit-identical in fp32 and fp64. New rays go
#                    to OS as RAY messages: one shadow ray per light the surface faces (carrying
#                    its contribution), then a reflection ray (Ks > 0), then a refraction ray
#                    (T > 0, no total internal reflection), both below the depth limit and,
#                    when render.min_weight > 0, only if their largest weight reaches it (golden
#                    applies the cut-off to these two, not to shadow rays). An eye ray's hit
#                    also sends COL an ID message (pixel, primitive id).
#   COLOR (from OS)  an unoccluded shadow ray's contribution: forwarded to COL as a pixel message.
#   MISS  (from OS)  a surface ray that left the scene: COL gets w x background (per component).
#
# Data: the scene block (lights, background, offset constants, max depth, min weight) in SC local memory at
# SCENE_BASE, the material records in SCGM at the HIT's luminance pointer (`ldg`, through SC's
# cache), both laid out by host/databases.py (docs/databases.md, "luminance_data").
# Ray counters at the data labels count_* (render reads them after the run).
#
# Serial mode (-D SERIAL_TREES=1, docs/kernels.md "Serial mode"): after a HIT is shaded and every
# ray it spawned is sent, SC sends OS SHADED (pixel) — on the same link and in the same buffer
# class as those RAYs, so it arrives after them — and OS counts the hit's ray as finished. Every
# way out of `hit` goes through `hit_done`; without SERIAL_TREES that label is `main` itself, so
# the program is the same as before.
#
# Specialisation (-D symbols from host/databases.py): the light loop runs over NLIGHTS lights
# (none assembled when NLIGHTS = 0); reflection code only `.if HAS_REFLECTION`, refraction code
# (and the T / eta loads) only `.if HAS_REFRACTION`. With every HAS_* = 1 (render --generic) the
# kernel tests Ks and T at run time and works on every scene.
#
# Timing (docs/timing.md): SC issues one operation per cycle and each register write needs its
# own cycle (one write port), so an fadd (2 cycles) cannot directly follow an fmul (3) and a
# 1-cycle op not two after an fmul: results must land in distinct cycles. fdiv (12), fsqrt (15)
# and fpow (30) are unpipelined and hold SC's single unit for their whole latency: nothing issues
# meanwhile, so they cannot be hidden — but pipelined work issued just before them completes
# inside them. The blocks below are ordered for that: the `# cN` notes give the issue cycle
# relative to the block's first instruction when every operand is on time (cache hits, FIFO
# words waiting); independent work fills the slots a dependency chain would leave empty.
# A RAY message is sent only after the last unpipelined operation of its ray, so a message never
# holds the SC -> OS link (and OS reading it) open across a long operation; its words fill the
# slots of the contribution's multiply chain instead.
#
# Structure:
#   start         constants into registers
#   main          dispatch on the message tag (COLOR first: it is the most frequent)
#   color         forward 4 words to COL, fall through into main
#   miss          w x background to COL
#   hit           receive, P, inside test, ID (eye rays), cosi, R (for every hit: nearly every
#                 hit faces a light or reflects), material loads
#   light         per light: L, dist, Ld, ndl (skip if <= 0), spec, contribution, RAY (shadow)
#   reflection    .if HAS_REFLECTION: RAY (P, R, w*Ks)
#   refraction    .if HAS_REFRACTION: Snell, TIR test, RAY (P, T dir, w*T)
#   *_cut         render.min_weight, out of line
#   hit_done      serial mode: SHADED to OS (otherwise another name of `main`)
#   drain         an unknown message: its payload is skipped

.proc sc
.include "protocol.inc"

.ifndef SERIAL_TREES
.equ SERIAL_TREES, 0              # one ray tree at a time (-D SERIAL_TREES=1)
.endif

.if MAT_INV_IOR != MAT_IOR + 1
.error "sc.s loads eta from [lum + MAT_INV_IOR - inside]: MAT_INV_IOR must follow MAT_IOR"
.endif

# ---- registers ---------------------------------------------------------------------------------
# Constants, set once at start.
.reg k_hdr_ray   = r1    # RAY header (SC -> OS)
.reg k_hdr_pix   = r2    # pixel message header (SC -> COL)
.reg k_hdr_id    = r3    # ID message header (SC -> COL)
.reg k_eps       = r4    # k_abs of the secondary-ray offset (SCN_EPS)
.reg k_inf       = r5    # +inf: t_max of reflection and refraction rays
.reg k_bg_r      = r6    # background colour
.reg k_bg_g      = r7
.reg k_bg_b      = r8
.reg k_max_bits  = r9    # max_depth << INFO_DEPTH_SHIFT
.reg k_min_w     = r10   # render.min_weight
.reg k_mw_on     = r11   # 1 if min_weight > 0 (the cut-off applies)
.reg k_one       = r12   # 1.0
.reg k_tag_hit   = r13
.reg k_tag_color = r14
.reg k_tag_miss  = r15
.reg k_light_end = r16   # LIGHTS_BASE + NLIGHTS * LIGHT_WORDS
# Ray counters (mirrored at count_* in local memory).
.reg n_eye       = r17
.reg n_refl      = r18
.reg n_refr      = r19
.reg n_shadow    = r20
# The message being served.
.reg hdr  = r21
.reg tag  = r22
# The hit (HIT payload order) and what is derived from it; these live through the whole hit.
.reg pix  = r23
.reg info = r24
.reg ox   = r25
.reg oy   = r26
.reg oz   = r27
.reg dx   = r28
.reg dy   = r29
.reg dz   = r30
.reg wr   = r31
.reg wg   = r32
.reg wb   = r33
.reg t    = r34
.reg ngx  = r35          # geometric normal
.reg ngy  = r36
.reg ngz  = r37
.reg nsx  = r38          # shading normal (flipped when the ray is inside)
.reg nsy  = r39
.reg nsz  = r40
.reg lum  = r41          # luminance pointer: the SCGM address of the material record
.reg prim = r42          # primitive id
.reg px   = r43          # P = o + t*d
.reg py   = r44
.reg pz   = r45
.reg cosi = r46          # -dot(d, Ns)
.reg rx   = r47          # R = normalize(d + (cosi + cosi)*Ns)
.reg ry   = r48
.reg rz   = r49
.reg kd_r = r50          # material: kdc = Kd*colour, Ks, shine, T, eta
.reg kd_g = r51
.reg kd_b = r52
.reg ks   = r53
.reg shine = r54
.reg dbits = r55         # depth << INFO_DEPTH_SHIFT (info without its kind)
.reg deeper = r56        # 1 if depth < max_depth: reflection / refraction allowed
.reg sinfo = r57         # info of the shadow rays: kind SHADOW, the hit's depth
.reg tmat = r58          # T
.reg eta  = r59          # ior if inside, else 1/ior
.reg lp   = r61          # light record pointer
# Temporaries: registers of the hit that are dead by then, named for each phase.
.reg inside = r60        # hit prologue: dot(d, Ng) > 0
.reg kind   = r62
.reg g0 = r21            # dot(d, Ng) partial products
.reg g1 = r22
.reg g2 = r42
.reg c0 = r35            # cosi and R: products (Ng is dead)
.reg c1 = r36
.reg c2 = r37
.reg two_cosi = r34      # (t is dead once P is known)
.reg rlen = r62
.reg eta_at = r24        # (info is dead once dbits, sinfo and kind are known)
.reg Lx = r25            # light loop: L = pos - P (o is dead)
.reg Ly = r26
.reg Lz = r27
.reg sqx = r35           # L*L
.reg sqy = r36
.reg sqz = r37
.reg len2 = r34
.reg dist = r62          # sqrt(dot(L, L))
.reg Ldx = r21           # Ld = L / dist
.reg Ldy = r22
.reg Ldz = r60
.reg nx_ = r35           # Ns*Ld products
.reg ny_ = r36
.reg nz_ = r37
.reg rdx_ = r25          # R*Ld products (L_a is dead once Ld_a is known)
.reg rdy_ = r26
.reg rdz_ = r27
.reg ndl = r42           # dot(Ns, Ld)
.reg face = r41          # ndl > 0
.reg spec = r25          # max(dot(R, Ld), 0) ** shine
.reg kr = r35            # kdc*ndl -> + Ks*spec -> * I -> * w: the contribution
.reg kg = r36
.reg kb = r37
.reg Ir = r26            # light intensity
.reg Ig = r27
.reg Ib = r34
.reg ksp = r41           # Ks*spec
.reg rwr = r25           # reflection: weight w*Ks
.reg rwg = r26
.reg rwb = r27
.reg rinfo = r22
.reg wmax = r21          # min_weight test
.reg e2 = r35            # refraction: eta*eta, cosi*cosi, 1 - cosi*cosi, kk
.reg cc = r36
.reg kk = r37
.reg ok = r21
.reg twr = r25           # weight w*T
.reg twg = r26
.reg twb = r27
.reg tinfo = r22
.reg coef = r34          # eta*cosi - sqrt(kk)
.reg vx = r41            # eta*d + coef*Ns, then the refraction direction
.reg vy = r42
.reg vz = r60
.reg cnx = r35           # coef*Ns, then squares
.reg cny = r36
.reg cnz = r62
.reg vlen = r36

.data
count_eye_hits:   .word 0
count_reflection: .word 0
count_refraction: .word 0
count_shadow:     .word 0
p_back:           .space 3        # the refraction ray's origin P - delta*Ng

.text
start:
    li k_hdr_ray, HDR_RAY_TO_OS
    li k_hdr_pix, HDR_PIXEL
    li k_hdr_id, HDR_ID
    ld k_eps, [SCENE_BASE + SCN_EPS]
    ld k_bg_r, [SCENE_BASE + SCN_BACKGROUND]
    ld k_bg_g, [SCENE_BASE + (SCN_BACKGROUND + 1)]
    ld k_bg_b, [SCENE_BASE + (SCN_BACKGROUND + 2)]
    ld k_max_bits, [SCENE_BASE + SCN_MAX_DEPTH]
    ld k_min_w, [SCENE_BASE + SCN_MIN_WEIGHT]
    slli k_max_bits, k_max_bits, INFO_DEPTH_SHIFT
    flt k_mw_on, r0, k_min_w          # golden: the cut-off applies only if min_weight > 0
    lf k_inf, inf
    lf k_one, 1.0
    li k_tag_hit, TAG_HIT
    li k_tag_color, TAG_COLOR
    li k_tag_miss, TAG_MISS
    li k_light_end, LIGHTS_BASE + NLIGHTS * LIGHT_WORDS
    li n_eye, 0
    li n_refl, 0
    li n_refr, 0
    li n_shadow, 0
    j main

# ---- COLOR: pixel, r, g, b -> the same four words to COL (falls through into main) ---------------
color:
    send col, k_hdr_pix
    recv ox, ring                     # pixel
    send col, ox
    recv ox, ring                     # r
    send col, ox
    recv ox, ring                     # g
    send col, ox
    recv ox, ring                     # b
    send col, ox

# ---- the message loop ----------------------------------------------------------------------------
main:
.if !SERIAL_TREES
hit_done:                             # a hit is shaded (serial mode: SHADED first, below)
.endif
    recv hdr, ring
    srli tag, hdr, HDR_TAG_SHIFT
    beq tag, k_tag_color, color
    beq tag, k_tag_hit, hit
    beq tag, k_tag_miss, miss
    andi ox, hdr, HDR_LENGTH_MASK     # not ours: skip the payload
drain:
    beqz ox, main
    recv oy, ring
    addi ox, ox, -1
    j drain

# ---- MISS: pixel, w -> COL gets w * background (golden: weight * background, per component) -----
miss:
    recv pix, ring
    recv wr, ring
    recv wg, ring
    fmul ox, wr, k_bg_r               # c3
    recv wb, ring
    fmul oy, wg, k_bg_g               # c5
    fmul oz, wb, k_bg_b               # c6
    send col, k_hdr_pix
    send col, pix
    send col, ox
    send col, oy
    send col, oz                      # c11: oz ready at c9
    j main

# ---- HIT ----------------------------------------------------------------------------------------
# Receive the hit; P = o + t*d and dot(d, Ng) start as soon as t and Ng arrive (an fmul and a
# recv alternate: their results land in alternate cycles).
hit:
    recv pix, ring
    recv info, ring
    recv ox, ring
    recv oy, ring
    recv oz, ring
    recv dx, ring
    recv dy, ring
    recv dz, ring
    recv wr, ring
    recv wg, ring
    recv wb, ring
    recv t, ring                      # c11
    fmul px, t, dx                    # c12  P = o + t*d: t*d first
    recv ngx, ring
    fmul py, t, dy
    recv ngy, ring
    fmul pz, t, dz
    recv ngz, ring
    fmul g0, dx, ngx                  # c18  dot(d, Ng) = (dx*ngx + dy*ngy) + dz*ngz
    recv nsx, ring
    fmul g1, dy, ngy
    recv nsy, ring
    fmul g2, dz, ngz
    recv nsz, ring
    fadd px, ox, px                   # c24
    fadd py, oy, py
    fadd g0, g0, g1
    fadd pz, oz, pz
    fadd g0, g0, g2                   # c28
    andi kind, info, 3                # c30 (c29: a write slot taken by g0)
    flt inside, r0, g0                # inside = dot(d, Ng) > 0
    recv lum, ring
    andi dbits, info, -4              # depth << INFO_DEPTH_SHIFT
    slt deeper, dbits, k_max_bits     # depth < max_depth
    ori sinfo, info, KIND_SHADOW      # shadow rays keep the hit's depth
    beqz inside, outside
    fneg nsx, nsx                     # seen from inside: Ns = -Ns
    fneg nsy, nsy
    fneg nsz, nsz
outside:
# Secondary-ray origins (docs/golden.md, "Secondary-ray origins"): delta = (((|Px*Ngx| +
# |Py*Ngy|) + |Pz*Ngz|) + t)*k_rel + k_abs, the hit's own bound on P's rounding along the normal,
# negated when the ray is inside, so delta*Ng points to the side the ray came from.
# Shadow and reflection rays leave from P + delta*Ng (it replaces P in px..pz), the refraction
# ray from P - delta*Ng (kept at p_back); all with t_min = 0. Ng is still in ngx..ngz here.
    fmul ox, px, ngx                  # (o is dead once P is known)
    fmul oy, py, ngy
    fmul oz, pz, ngz
    ld g1, [SCENE_BASE + SCN_EPS_REL] # k_rel
    fabs ox, ox
    fabs oy, oy
    fabs oz, oz
    fadd ox, ox, oy
    fadd ox, ox, oz                   # sum |P_a*Ng_a|
    fadd ox, ox, t
    fmul ox, ox, g1
    fadd ox, ox, k_eps                # delta
    beqz inside, offset_out
    fneg ox, ox
offset_out:
    fmul oy, ox, ngx                  # delta*Ng
    fmul oz, ox, ngy
    fmul g1, ox, ngz
.if HAS_REFRACTION
    fsub g0, px, oy                   # P - delta*Ng: the refraction ray's origin
    st g0, [p_back]
    fsub g0, py, oz
    st g0, [p_back + 1]
    fsub g0, pz, g1
    st g0, [p_back + 2]
.endif
    fadd px, px, oy                   # P + delta*Ng
    fadd py, py, oz
    fadd pz, pz, g1
# cosi = -dot(d, Ns); R = normalize(d + (cosi + cosi)*Ns), computed for every hit (the lights'
# highlights and the reflection ray use it). The eye ray's ID message and the material loads
# (a cache hit holds issue 2 cycles) sit in the slots the dependency chain leaves.
    recv prim, ring
    fmul c0, dx, nsx                  # c0   dot(d, Ns)
    fmul c1, dy, nsy
    fmul c2, dz, nsz
    bnez kind, not_eye                # c3
    send col, k_hdr_id                #      an eye ray's hit: its primitive to COL's hit-id buffer
    send col, pix
    send col, prim
    addi n_eye, n_eye, 1
    st n_eye, [count_eye_hits]
not_eye:
    fadd c0, c0, c1                   # u0 (c6 after a secondary ray's hit, c10 after an eye ray's)
    ldg kd_r, [lum + MAT_KDC]         # u1
    fadd c0, c0, c2                   # u3
    ldg kd_g, [lum + (MAT_KDC + 1)]   # u4
    fneg cosi, c0                     # u6   cosi = -dot(d, Ns)
    fadd two_cosi, cosi, cosi         # u7
    ldg kd_b, [lum + (MAT_KDC + 2)]   # u8
    fmul c0, two_cosi, nsx            # u10  (cosi + cosi)*Ns
    fmul c1, two_cosi, nsy
    fmul c2, two_cosi, nsz
    fadd rx, dx, c0                   # u14  d + (cosi + cosi)*Ns
    fadd ry, dy, c1
    fadd rz, dz, c2
    fmul c0, rx, rx                   # u17  dot(R, R)
    fmul c1, ry, ry
    fmul c2, rz, rz
    fadd c0, c0, c1                   # u21
    ldg ks, [lum + MAT_KS]            # u22
    fadd c0, c0, c2                   # u24
    ldg shine, [lum + MAT_SHINE]      # u25
.if HAS_REFRACTION
    sub eta_at, lum, inside           # u27  eta = ior inside, 1/ior outside: one load
    ldg tmat, [lum + MAT_T]
    ldg eta, [eta_at + MAT_INV_IOR]
.endif
    fsqrt rlen, c0                    # u27 (u32 with refraction)
    li lp, LIGHTS_BASE                #      (lands after the sqrt: no slot before it takes a write)
    fdiv rx, rx, rlen
    fdiv ry, ry, rlen
    fdiv rz, rz, rlen

# ---- shadow rays, light by light (file order) ---------------------------------------------------
.if NLIGHTS > 0
light:
    ld Lx, [lp + LIGHT_POS]           # c0   L = pos - P
    ld Ly, [lp + (LIGHT_POS + 1)]
    fsub Lx, Lx, px
    fsub Ly, Ly, py
    fmul sqx, Lx, Lx                  # c4   dot(L, L)
    ld Lz, [lp + (LIGHT_POS + 2)]
    fsub Lz, Lz, pz
    fmul sqy, Ly, Ly
    fmul sqz, Lz, Lz                  # c8
    fadd len2, sqx, sqy               # c10
    fadd len2, len2, sqz              # c12
    fsqrt dist, len2                  # c14  dist = sqrt(dot(L, L))
    fdiv Ldx, Lx, dist                # c29  Ld = L / dist; the Ns.Ld and R.Ld products of
    fmul nx_, nsx, Ldx                #      each component run during the next division
    fmul rdx_, rx, Ldx
    fdiv Ldy, Ly, dist                # c43
    fmul ny_, nsy, Ldy
    fmul rdy_, ry, Ldy
    fadd nx_, nx_, ny_                # c58
    fadd rdx_, rdx_, rdy_
    fdiv Ldz, Lz, dist                # c60
    fmul nz_, nsz, Ldz                # c72
    fmul rdz_, rz, Ldz
    fadd ndl, nx_, nz_                # c75  ndl = dot(Ns, Ld)
    fadd rdx_, rdx_, rdz_             #      dot(R, Ld)
    flt face, r0, ndl                 # c78  no shadow ray unless ndl > 0
    beqz face, next_light
    ld Ir, [lp + LIGHT_INT]           # c0
    ld Ig, [lp + (LIGHT_INT + 1)]
    ld Ib, [lp + (LIGHT_INT + 2)]
    fmax spec, rdx_, r0               # c3   max(dot(R, Ld), 0)
    fmul kr, kd_r, ndl                # c4   kdc*ndl
    addi n_shadow, n_shadow, 1
    fmul kg, kd_g, ndl
    fmul kb, kd_b, ndl
    fpow spec, spec, shine            # c8   ** shine
    fmul ksp, ks, spec                # c38  c = ((kdc*ndl + Ks*spec) * I) * w
    send ring, k_hdr_ray              #      the shadow ray: P, Ld, eps, dist, c
    send ring, pix
    fadd kr, kr, ksp                  # c41
    fadd kg, kg, ksp
    fadd kb, kb, ksp
    fmul kr, kr, Ir                   # c44
    fmul kg, kg, Ig
    fmul kb, kb, Ib
    send ring, sinfo
    fmul kr, kr, wr                   # c48
    fmul kg, kg, wg
    fmul kb, kb, wb
    send ring, px
    send ring, py
    send ring, pz
    send ring, Ldx
    send ring, Ldy
    send ring, Ldz
    send ring, r0                     #      t_min = 0: the origin is off the surface
    send ring, dist
    send ring, kr
    send ring, kg
    send ring, kb                     # c61
next_light:
    addi lp, lp, LIGHT_WORDS
    bne lp, k_light_end, light
    st n_shadow, [count_shadow]
.endif

# ---- reflection and refraction (depth < max_depth) ----------------------------------------------
.if HAS_REFLECTION || HAS_REFRACTION
    beqz deeper, hit_done
.endif
.if HAS_REFLECTION
reflection:
    flt ok, r0, ks                    # Ks > 0
    beqz ok, no_reflection
    addi rinfo, dbits, (1 << INFO_DEPTH_SHIFT) + KIND_REFLECTION    # depth + 1
    fmul rwr, wr, ks                  # weight w*Ks
    fmul rwg, wg, ks
    fmul rwb, wb, ks
    bnez k_mw_on, reflection_cut      # render.min_weight: out of line
reflection_send:
    send ring, k_hdr_ray
    send ring, pix
    send ring, rinfo
    send ring, px
    send ring, py
    send ring, pz
    send ring, rx
    send ring, ry
    send ring, rz
    send ring, r0                     #      t_min = 0: the origin is off the surface
    send ring, k_inf
    send ring, rwr
    send ring, rwg
    send ring, rwb
    addi n_refl, n_refl, 1
    st n_refl, [count_reflection]
no_reflection:
.endif
.if HAS_REFRACTION
refraction:
    flt ok, r0, tmat                  # c0   T > 0
    addi tinfo, dbits, (1 << INFO_DEPTH_SHIFT) + KIND_REFRACTION    # depth + 1
    beqz ok, hit_done
    fmul cc, cosi, cosi               # c3   kk = 1 - (eta*eta)*(1 - cosi*cosi)
    fmul e2, eta, eta
    fmul twr, wr, tmat                #      weight w*T
    fmul twg, wg, tmat
    fmul twb, wb, tmat
    fsub cc, k_one, cc                # c9
    fmul coef, eta, cosi              # c10  eta*cosi
    fmul e2, e2, cc
    fmul vx, eta, dx                  # c12  eta*d
    fmul vy, eta, dy
    fmul vz, eta, dz
    bnez k_mw_on, refraction_cut      # c15  render.min_weight: out of line
refraction_keep:
    fsub kk, k_one, e2                # c16
    fle ok, r0, kk                    # c18  kk < 0 (or NaN): total internal reflection
    beqz ok, hit_done
    addi n_refr, n_refr, 1
    fsqrt kk, kk                      # c21
    fsub coef, coef, kk               # c36  (eta*cosi) - sqrt(kk)
    st n_refr, [count_refraction]
    fmul cnx, coef, nsx               # c38  coef*Ns
    fmul cny, coef, nsy
    fmul cnz, coef, nsz
    fadd vx, vx, cnx                  # c42  eta*d + coef*Ns
    fadd vy, vy, cny
    fadd vz, vz, cnz
    fmul cnx, vx, vx                  # c45  normalize
    fmul cny, vy, vy
    fmul cnz, vz, vz
    fadd cnx, cnx, cny                # c49
    fadd cnx, cnx, cnz                # c51
    ld px, [p_back]                   #      the refraction ray leaves from P - delta*Ng
    ld py, [p_back + 1]
    ld pz, [p_back + 2]
    fsqrt vlen, cnx                   # c53
    fdiv vx, vx, vlen
    fdiv vy, vy, vlen
    fdiv vz, vz, vlen
    send ring, k_hdr_ray              # c104 the refraction ray: P, direction, eps, +inf, w*T
    send ring, pix
    send ring, tinfo
    send ring, px
    send ring, py
    send ring, pz
    send ring, vx
    send ring, vy
    send ring, vz
    send ring, r0                     #      t_min = 0: the origin is off the surface
    send ring, k_inf
    send ring, twr
    send ring, twg
    send ring, twb
.endif
.if SERIAL_TREES
# ---- serial mode: the hit is shaded and every ray it spawned is on its way to OS ---------------
hit_done:
    li hdr, HDR_SHADED                # (hdr is free: the next message is not received yet)
    send ring, hdr
    send ring, pix
.endif
    j main

# ---- render.min_weight (golden: a spawned ray is dropped if its largest weight is below it) ------
.if HAS_REFLECTION
reflection_cut:
    fmax wmax, rwr, rwg
    fmax wmax, wmax, rwb
    fle ok, k_min_w, wmax             # max(w) >= min_weight (NaN: dropped)
    bnez ok, reflection_send
    j no_reflection
.endif
.if HAS_REFRACTION
refraction_cut:
    fmax wmax, twr, twg
    fmax wmax, wmax, twb
    fle ok, k_min_w, wmax
    bnez ok, refraction_keep
    j hit_done
.endif
