"""The debugger's commands: usage, help texts and aliases (`help`, tab completion, dispatch)."""

from __future__ import annotations

# name -> (usage, one line, more)
HELP: dict[str, tuple[str, str, str]] = {
    "step": ("step [N]", "run N cycles (default 1)",
             "Stops early at a breakpoint, a watchpoint or the end of the run. Alias: s."),
    "stepi": ("stepi [N]", "run until the viewed processor has issued N bundles",
              "Cycles in which it stalls do not count. Alias: si."),
    "next": ("next [N]", "like stepi, but a call counts as one bundle with its whole subroutine",
             "Alias: n."),
    "continue": ("continue", "run until a breakpoint, a watchpoint or the end of the run",
                 "Ctrl-C stops it between two cycles. Alias: c."),
    "until": ("until [LOCATION]", "run until the viewed processor issues the bundle at LOCATION",
              "Without a location: until it issues a bundle after the current one (leave a "
              "loop). Alias: u."),
    "break": ("break LOCATION [if CONDITION]",
              "stop in the cycle the bundle at LOCATION issues (and CONDITION holds)",
              "LOCATION is a label or an address, optionally `label+N`, qualified as ic.loop or "
              "pe1.ic.loop; unqualified it means the viewed processor on every PE. CONDITION is "
              "an expression evaluated after that cycle, e.g. `break loop if r9 == 2 && "
              "f:r7 < 1.5`. Alias: b."),
    "watch": ("watch REGISTER|ADDRESS",
              "stop in every cycle that writes a register or a local memory word",
              "Reports old -> new value, the cycle, and the bundle that wrote it (for a register: "
              "the op, its PC and its issue cycle). ADDRESS: local[E], a data label or a number "
              "(local memory). Views: watch f:r6 shows floats."),
    "delete": ("delete [N]", "delete breakpoint or watchpoint N (all without N)", "Alias: d."),
    "info": ("info break|registers|fifo|cache|stats|scoreboard|checkpoints|state",
             "show breakpoints, all registers, FIFOs and CMU locks, cache, counters, ...",
             "`info state` prints a digest of the machine's entire state (equal digests: equal "
             "states). Alias: i."),
    "print": ("print[/x|/d|/u|/f] EXPRESSION", "evaluate an expression",
              "Names: r5, zero, lr, pc, cycle, labels, -D symbols; memory local[E], resident[E], "
              "icgm[E], scgm[E], global[E]; another processor: ic.r5, pe1.sc.local[3]; views: "
              "f:r5 (float), u:, x:, i:. Operators as in the assembler (C). Alias: p."),
    "x": ("x/N[x|d|u|f|a] [REGION] ADDRESS", "dump N words of memory",
          "REGION: local (default), resident, icgm, scgm, global; e.g. `x/8 icgm 512`, "
          "`x/4f local[table]`. Formats: x hex (default), d signed, u unsigned, f float, a all."),
    "disassemble": ("disassemble [LOCATION]", "list the bundles from LOCATION to the next label",
                    "Without a location: the code around the PC. Every slot is shown. "
                    "Alias: disas."),
    "proc": ("proc os|ic|sc", "view another processor of the PE", ""),
    "pe": ("pe K", "view another PE", ""),
    "set": ("set REGISTER=VALUE | set *ADDRESS=VALUE | set pc=LOCATION",
            "write a register, a local memory word or the PC",
            "A float value (1.5, 1.5f, or any value written to f:rN) is stored as a float, an "
            "integer as an integer; x:rN=0x3f800000 stores raw bits. Resident and global memory "
            "are read-only (the host writes them). An edit becomes part of the run's history: "
            "reverse steps before it undo it."),
    "reverse-step": ("reverse-step [N]", "go back N cycles (exactly: checkpoints + replay)",
                     "Not before the start of the history: cycle 0, or the cycle where "
                     "--fast-forward handed the machine over. Alias: rs."),
    "reverse-stepi": ("reverse-stepi [N]",
                      "go back to the stop after the viewed processor's N-th previous bundle",
                      "Alias: rsi."),
    "reverse-continue": ("reverse-continue",
                         "go back to the latest earlier cycle where a breakpoint or watchpoint "
                         "fires", "Alias: rc."),
    "trace": ("trace on|off", "print a line per cycle per processor of the PE while running", ""),
    "screen": ("screen [on|off]", "draw the panels now; on/off: draw them after every stop", ""),
    "restart": ("restart", "start the run again from a freshly built machine",
                "Breakpoints and watchpoints stay; edits are lost. After --fast-forward: back "
                "to the state it handed over."),
    "source": ("source FILE", "run the commands in FILE", "Lines starting with # are comments."),
    "help": ("help [COMMAND]", "list the commands, or explain one", "Alias: h."),
    "quit": ("quit", "leave the debugger", "Also: q, exit, end of input."),
}

ALIASES = {"s": "step", "si": "stepi", "n": "next", "c": "continue", "cont": "continue",
           "u": "until", "b": "break", "d": "delete", "i": "info", "p": "print",
           "disas": "disassemble", "rs": "reverse-step", "rsi": "reverse-stepi",
           "rc": "reverse-continue", "h": "help", "q": "quit", "exit": "quit"}

INFO_TOPICS = ("break", "registers", "fifo", "cache", "stats", "scoreboard", "checkpoints", "state")
MOVES = ("step", "stepi", "next", "continue", "until", "reverse-step", "reverse-stepi",
         "reverse-continue", "restart")
