# IC: takes SC's two-word message, then waits for a word that never comes
    recv r1, ring
    recv r2, ring
tail:
    recv r3, ring
    halt
