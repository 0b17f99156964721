.proc ic
        halt
