# SC: sends IC a two-word message (class 1), then waits for OS
    li r1, (1 << HDR_CLS_SHIFT) | (DEST_IC << HDR_DEST_SHIFT) | 2
    send ring, r1
    li r2, 11
    send ring, r2
wait_os:
    recv r3, ring
    recv r4, ring
    send ring, r4
    halt
