# Dot product of N pairs of floats in IC's resident memory (a0, b0, a1, b1, ... from address
# PAIRS): linear assembly. The `.sched` region holds one operation per line in serial order; the
# assembler bundles it for the machine it assembles for, and software-pipelines the `.pipeline`
# loop (docs/scheduling.md). Assembled with `--no-schedule` (or outside a region) the same lines
# run one operation per bundle: the serial form the tests compare it with.
#
#   netsushisen asm kernels/examples/dot_ic.s --stats -D N=64        # the pipelining information
#
# The result is left in r10 (sum), the index past the last pair in r1.
.proc ic
.ifndef N
.equ N, 64
.endif
.ifndef PAIRS
.equ PAIRS, 0
.endif
.reg i = r1
.reg a = r2
.reg b = r3
.reg product = r4
.reg end = r9
.reg sum = r10

.sched
.temps r40-r47                  # registers the pipeliner may use for copies and its guard
        li i, PAIRS
        li end, PAIRS + 2 * N
        lf sum, 0.0
        bge i, end, done        # N = 0: no iteration (the loop body runs before its test)
.pipeline
loop:   ldr a, [i + 0]
        ldr b, [i + 1]
        fmul product, a, b
        fadd sum, sum, product
        addi i, i, 2
        blt i, end, loop
done:   halt
.endsched
