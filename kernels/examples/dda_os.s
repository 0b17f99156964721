# Sample OS program: one 3-D DDA step over a uniform grid, per-axis work in parallel slots.
.proc os
.reg tmx = r1
.reg tmy = r2
.reg tmz = r3
.reg tdx = r4
.reg tdy = r5
.reg tdz = r6
.reg ix = r7
.reg iy = r8
.reg iz = r9
.reg sx = r10
.reg sy = r11
.reg sz = r12
.equ NX, 16
.equ NY, 16
.equ NZ, 16
step:
    { flt r13, tmx, tmy ; flt r14, tmx, tmz }
    { and r15, r13, r14 ; flt r16, tmy, tmz }
    bnez r15, step_x
    bnez r16, step_y
step_z:
    { add iz, iz, sz ; fadd tmz, tmz, tdz }
    { sltu r17, iz, r18 }
    j visit
step_x:
    { add ix, ix, sx ; fadd tmx, tmx, tdx }
    j visit
step_y:
    { add iy, iy, sy ; fadd tmy, tmy, tdy }
visit:
    { li r19, NX * NY ; li r20, NX }
    { mul r21, iz, r19 ; mul r22, iy, r20 }
    { add r23, r21, r22 }
    { add r23, r23, ix }
    { ld r24, [r23 + 0] }
    beqz r24, step
    { li r25, DEST_IC << HDR_DEST_SHIFT | 2 }
    send ring, r25
    send ring, r24
    send ring, tmx
    poll r26, ring
    beqz r26, step
    { recv r27, ring }
    halt
