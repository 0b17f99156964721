# SC: MISS -> pixel message with w * background; counts nothing but eye hits (0).
.proc sc
.include "protocol.inc"
.data
count_eye_hits: .word 0
count_reflection: .word 0
count_refraction: .word 0
count_shadow: .word 0
.text
        li r9, HDR_PIXEL
loop:   recv r1, ring                    # MISS header
        recv r2, ring                    # pixel
        recv r3, ring
        recv r4, ring
        recv r5, ring
        ld r6, [SCENE_BASE + SCN_BACKGROUND]
        ld r7, [SCENE_BASE + SCN_BACKGROUND + 1]
        ld r8, [SCENE_BASE + SCN_BACKGROUND + 2]
        fmul r3, r3, r6
        fmul r4, r4, r7
        fmul r5, r5, r8
        send col, r9
        send col, r2
        send col, r3
        send col, r4
        send col, r5
        j loop
