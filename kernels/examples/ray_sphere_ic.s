# Sample IC program: ray against a list of spheres in resident memory, nearest hit.
# A worked example of IC scheduling (the real kernel is kernels/ic.s); the fuzz tests mutate it.
.proc ic
.equ SPHERE_WORDS, 4            # cx cy cz r
.reg ox = r1
.reg oy = r2
.reg oz = r3
.reg dx = r4
.reg dy = r5
.reg dz = r6
.reg tbest = r7
.reg ptr = r8
.reg count = r9
.data
zero_f: .float 0.0
big:    .float 1e30
.text
start:
    recv r20, ring                      # header
    { recv ox, ring }
    recv oy, ring
    recv oz, ring
    recv dx, ring
    recv dy, ring
    recv dz, ring
    recv ptr, ring
    recv count, ring
    { ld tbest, [big] ; lf r21, 0.0 }
loop:
    beqz count, done
    { ldr r10, [ptr + 0] }
    { ldr r11, [ptr + 1] ; fmov r26, ox }
    { ldr r12, [ptr + 2] ; fsub r13, r10, ox }
    { ldr r14, [ptr + 3] ; fsub r15, r11, oy ; fsub r16, r12, oz }
    { fmul r17, r13, dx ; fmul r18, r15, dy ; fmul r19, r16, dz }
    { fmul r22, r14, r14 ; fadd r23, r17, r18 }
    { fadd r23, r23, r19 }              # b = oc . d
.if SPHERE_WORDS == 4
    { fmul r24, r13, r13 ; fmul r25, r15, r15 ; fmul r26, r16, r16 }
.endif
    { fadd r24, r24, r25 ; fmul r27, r23, r23 ; addi ptr, ptr, SPHERE_WORDS }
    { fadd r24, r24, r26 }
    { fsub r24, r24, r22 }              # c = |oc|^2 - r^2
    { fsub r28, r27, r24 }              # disc = b^2 - c
    { flt r29, r28, r21 }
    bnez r29, next
    { fsqrt r30, r28 }
    { fsub r31, r23, r30 }
    { flt r29, r31, tbest ; flt r32, r21, r31 }
    { and r29, r29, r32 }
    { fsel tbest, r29, r31, tbest }
next:
    { addi count, count, -1 }
    j loop
done:
    li r33, DEST_SC << HDR_DEST_SHIFT | 1
    send ring, r33
    send ring, tbest
    j start
