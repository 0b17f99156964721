# Test kernels for the render pipeline: OS turns every eye ray into a MISS (no traversal).
.proc os
.include "protocol.inc"
loop:   recv r1, host                    # RAY header
        recv r2, host                    # pixel
        recv r3, host                    # info
        li r20, RAY_WORDS - 2 - 3        # skip o, d, t_min, t_max (8 words)
skip:   recv r4, host
        addi r20, r20, -1
        bnez r20, skip
        recv r5, host                    # w
        recv r6, host
        recv r7, host
        li r8, HDR_MISS
        send ring, r8
        send ring, r2
        send ring, r5
        send ring, r6
        send ring, r7
        j loop
