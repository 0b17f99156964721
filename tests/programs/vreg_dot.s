# a dot product in linear assembly: every value a .vreg name
.proc ic
.equ N, 8
.data
xs: .float 1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0
ys: .float 0.5, -1.0, 2.0, 0.25, 1.5, -2.0, 3.0, 1.0
.text
.sched
.temps auto
.vreg i, end, sum, a, b, p, pa, pb
.vreg out = r5
        li i, 0
        li end, N
        li pa, xs
        li pb, ys
        lf sum, 0.0
loop:   ld a, [pa]
        ld b, [pb]
        fmul p, a, b
        fadd sum, sum, p
        addi pa, pa, 1
        addi pb, pb, 1
        addi i, i, 1
        blt i, end, loop
        fmov out, sum
        halt
.endsched
