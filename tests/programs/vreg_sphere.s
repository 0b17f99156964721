# a 3-component sphere test in linear assembly: oc = o - c, b = oc.d, q = oc - b d,
# disc = rr - q.q (golden's order), every temporary a .vreg
.proc ic
.data
ray: .float 0.25, -1.5, 0.5, 0.6, 0.0, 0.8
sph: .float 1.0, 0.5, 2.0, 2.25
.text
.sched
.temps r40-r59
.vreg ox, oy, oz, dx, dy, dz, cx, cy, cz, rr, ocx, ocy, ocz, bx, by, bz, b, qx, qy, qz, qq
.vreg disc = r5, bout = r6
        ld ox, [ray]
        ld oy, [ray + 1]
        ld oz, [ray + 2]
        ld dx, [ray + 3]
        ld dy, [ray + 4]
        ld dz, [ray + 5]
        ld cx, [sph]
        ld cy, [sph + 1]
        ld cz, [sph + 2]
        ld rr, [sph + 3]
        fsub ocx, ox, cx
        fsub ocy, oy, cy
        fsub ocz, oz, cz
        fmul bx, ocx, dx
        fmul by, ocy, dy
        fmul bz, ocz, dz
        fadd b, bx, by
        fadd b, b, bz
        fmul qx, b, dx
        fmul qy, b, dy
        fmul qz, b, dz
        fsub qx, ocx, qx
        fsub qy, ocy, qy
        fsub qz, ocz, qz
        fmul qx, qx, qx
        fmul qy, qy, qy
        fmul qz, qz, qz
        fadd qq, qx, qy
        fadd qq, qq, qz
        fsub disc, rr, qq
        fmov bout, b
        halt
.endsched
