# OS: counts down, then sends SC two one-word messages
    li r5, 10
delay:
    addi r5, r5, -1
    bnez r5, delay
    li r1, (DEST_SC << HDR_DEST_SHIFT) | 1
    send ring, r1
    send ring, r1
    halt
