"""The debugger's commands: usage, help texts and aliases (`help`, tab completion, dispatch).

Aliases are listed once, by `help COMMAND` from ALIASES (the texts do not repeat them)."""

from __future__ import annotations

# name -> (usage, one line, more)
HELP: dict[str, tuple[str, str, str]] = {
    "cycle": ("cycle [N]", "run N cycles (default 1)",
              "Stops early at a breakpoint, a watchpoint or the end of the run."),
    "step": ("step [N]", "run the viewed processor to the next source line (N lines)",
             "gdb's step: until its next bundle holds other source lines. In a .sched region a "
             "bundle holds operations of several lines and the lines come in the schedule's "
             "order (gdb on optimised code); stepi moves one bundle, cycle one cycle."),
    "stepi": ("stepi [N]", "run until the viewed processor has issued N bundles",
              "Cycles in which it stalls do not count."),
    "next": ("next [N]", "like step, but a call runs to its return as part of the line", ""),
    "nexti": ("nexti [N]", "like stepi, but a call counts as one bundle with its whole "
              "subroutine", ""),
    "continue": ("continue [N]", "run until a breakpoint, a watchpoint or the end of the run",
                 "Ctrl-C stops it between two cycles. With N: ignore the breakpoint that "
                 "stopped the run N-1 more times (gdb's `continue N`)."),
    "until": ("until [LOCATION]", "run until the viewed processor issues the bundle at LOCATION",
              "Without a location: until it issues a bundle after the current one (leave a "
              "loop)."),
    "finish": ("finish", "run until the viewed processor returns from the current subroutine",
               "Stops after the `ret` that leaves the routine the processor is in (calls made "
               "on the way return first). Not meaningful outside a subroutine (lr is 0: no "
               "call has been made)."),
    "break": ("break LOCATION [if CONDITION]",
              "stop in the cycle the bundle at LOCATION issues (and CONDITION holds)",
              "LOCATION is a label or an address, optionally `label+N`, qualified as ic.loop or "
              "pe1.ic.loop, or FILE:LINE (sum.s:9: the first bundle of that source line, or of "
              "the next line with code); unqualified it means the viewed processor on every PE. "
              "CONDITION is an expression evaluated after that cycle, e.g. `break loop if r9 == "
              "2 && f:r7 < 1.5`."),
    "tbreak": ("tbreak LOCATION [if CONDITION]", "a breakpoint deleted when it first stops",
               "As break; `info breakpoints` shows it with Disp `del`."),
    "watch": ("watch REGISTER|ADDRESS|*ADDR",
              "stop in every cycle that writes a register or a local memory word",
              "Reports old -> new value, the cycle, and the bundle that wrote it (for a register: "
              "the op, its PC and its issue cycle). ADDRESS: local[E], a data label or a number "
              "(local memory), or gdb's *ADDR (the word at ADDR of local memory: watch *12). "
              "Views: watch f:r6 shows floats."),
    "rwatch": ("rwatch ADDRESS|*ADDR", "stop in every cycle that reads a memory word",
               "Any memory: local[E], resident[E], icgm[E], scgm[E] (global memory: a read by "
               "any PE); *ADDR is gdb's spelling (*12: local[12], *icgm 12). Reports the value read, the loading op and, for a global word, whether "
               "the cache hit or missed."),
    "awatch": ("awatch ADDRESS|*ADDR", "stop in every cycle that reads or writes a memory word",
               "Reads as rwatch reports them, writes (local memory) as watch."),
    "delete": ("delete [N...]", "delete breakpoints, watchpoints (all without N)",
               "N may be a range: delete 2-4."),
    "disable": ("disable [N...]", "disable breakpoints or watchpoints (all without N)",
                "A disabled breakpoint stays in `info breakpoints` (Enb n) but never stops."),
    "enable": ("enable [N...]", "enable breakpoints or watchpoints (all without N)", ""),
    "condition": ("condition N [EXPRESSION]",
                  "stop at breakpoint N only when EXPRESSION holds; without it: always",
                  "The expression is checked when given and evaluated after the cycle the "
                  "bundle issues in, as with break ... if."),
    "ignore": ("ignore N COUNT", "let breakpoint N pass its next COUNT crossings",
               "A crossing is a hit whose condition holds; ignored crossings count as hits."),
    "display": ("display[/x|/d|/u|/f] [EXPRESSION]",
                "print EXPRESSION now and at every stop; without it: print them all",
                "Numbered; `undisplay N` removes one, `info display` lists them."),
    "undisplay": ("undisplay [N...]", "stop displaying expressions (all without N)", ""),
    "list": ("list [LOCATION|FILE:LINE|-]", "show source lines",
             "Without an argument: around the viewed processor's PC, then the next lines on "
             "each repeat; `list -`: the lines before. LOCATION: a label or an address (list "
             "loop), or FILE:LINE. Marks: => the PC's line, B1 a breakpoint's."),
    "info": ("info TOPIC", "breakpoints, display, registers [REG...], line [LINE|*ADDR], "
             "symbol ADDR, loop, fifo, cache, stats, scoreboard, checkpoints, state",
             "`info breakpoints` is gdb's table (Num Type Disp Enb Address What) with hit "
             "counts. `info registers pri r5` shows only those. `info line 12` (or FILE:LINE, a "
             "label, *ADDR; the PC's line without one) says which bundles hold a source line; "
             "`info symbol 12` which label an address is at or after (code and data). `info "
             "loop` the bound per iteration of the loop around the PC (units, ports, "
             "recurrence) beside the cycles per iteration achieved so far. "
             "`info state` prints a digest of the machine's entire state (equal digests: equal "
             "states)."),
    "print": ("print[/x|/d|/u|/f] EXPRESSION", "evaluate an expression",
              "Names: r5, zero, lr, pc, cycle, labels, -D symbols; memory local[E], resident[E], "
              "icgm[E], scgm[E], global[E]; another processor: ic.r5, pe1.sc.local[3]; views: "
              "f:r5 (float), u:, x:, i:. Operators as in the assembler (C)."),
    "x": ("x/N[x|d|u|f|a|i] [REGION] ADDRESS", "dump N words of memory (or N bundles: x/Ni)",
          "REGION: local (the data memory, default), resident, icgm, scgm, global; e.g. "
          "`x/8 icgm 512`, `x/4f local[table]`, `x/4f 12`, `x/4xw *12` (gdb's spellings). "
          "Formats: x hex (default), d signed, u unsigned, f float, a all, i bundles from a "
          "code location (x/3i pc, x/4i loop)."),
    "disassemble": ("disassemble [LOCATION]", "list the bundles from LOCATION to the next label",
                    "Without a location: the code around the PC. Every slot is shown."),
    "proc": ("proc os|ic|sc", "view another processor of the PE", ""),
    "pe": ("pe K", "view another PE", ""),
    "layout": ("layout [auto|asm|regs|full|PANEL...]", "choose the panels of the screen",
               "auto (default): as many panels as the terminal holds, one stop per screen "
               "(80x24: listing and registers). asm: the listing; regs: listing and registers; "
               "full: every panel. Or name panels: layout listing registers fifos (listing, "
               "registers, scoreboard, fifos, memory, counters). Without an argument: the "
               "current choice."),
    "set": ("set REGISTER=VALUE | set *ADDRESS=VALUE | set pc=LOCATION",
            "write a register, a local memory word or the PC",
            "A float value (1.5, 1.5f, or any value written to f:rN) is stored as a float, an "
            "integer as an integer; x:rN=0x3f800000 stores raw bits. Resident and global memory "
            "are read-only (the host writes them). An edit becomes part of the run's history: "
            "reverse steps before it undo it."),
    "reverse-cycle": ("reverse-cycle [N]", "go back N cycles (exactly: checkpoints + replay)",
                      "Not before the start of the history: cycle 0, or the cycle where "
                      "--fast-forward handed the machine over."),
    "reverse-step": ("reverse-step [N]", "go back to the previous source line (N lines)",
                     "Back to where the viewed processor's PC last held other source lines."),
    "reverse-stepi": ("reverse-stepi [N]",
                      "go back to the stop after the viewed processor's N-th previous bundle", ""),
    "reverse-continue": ("reverse-continue",
                         "go back to the latest earlier cycle where a breakpoint or watchpoint "
                         "fires", ""),
    "trace": ("trace on|off", "print a line per cycle per processor of the PE while running", ""),
    "screen": ("screen [on|off]", "draw the panels now; on/off: draw them after every stop", ""),
    "restart": ("restart", "start the run again from a freshly built machine",
                "Breakpoints and watchpoints stay; edits are lost. After --fast-forward: back "
                "to the state it handed over."),
    "source": ("source FILE", "run the commands in FILE", "Lines starting with # are comments."),
    "help": ("help [COMMAND|all]", "the index of commands; help COMMAND explains one",
             "help all: every command with its one-line description (paged on a terminal, as "
             "all long output is: Enter for more, q to quit, c to continue without paging)."),
    "quit": ("quit", "leave the debugger", "Also at the end of input."),
}

CLASSES = (  # the index `help` prints (gdb's `help` lists classes of commands)
    ("running", ("step", "next", "stepi", "nexti", "cycle", "continue", "until", "finish",
                 "restart")),
    ("backwards", ("reverse-step", "reverse-stepi", "reverse-cycle", "reverse-continue")),
    ("breakpoints", ("break", "tbreak", "delete", "disable", "enable", "condition", "ignore")),
    ("watching", ("watch", "rwatch", "awatch")),
    ("data", ("print", "display", "undisplay", "x", "set", "info")),
    ("code", ("list", "disassemble")),
    ("screen", ("proc", "pe", "layout", "screen", "trace")),
    ("other", ("source", "help", "quit")),
)

ALIASES = {"s": "step", "si": "stepi", "n": "next", "ni": "nexti", "c": "continue",
           "cont": "continue", "cy": "cycle", "rcy": "reverse-cycle",
           "u": "until", "fin": "finish", "b": "break", "tb": "tbreak", "d": "delete",
           "dis": "disable", "en": "enable", "i": "info", "p": "print", "l": "list",
           "disas": "disassemble", "rs": "reverse-step", "rsi": "reverse-stepi",
           "rc": "reverse-continue", "h": "help", "q": "quit", "exit": "quit"}

INFO_TOPICS = ("breakpoints", "display", "registers", "line", "symbol", "loop", "fifo", "cache",
               "stats", "scoreboard", "checkpoints", "state")
INFO_ALIASES = {"b": "breakpoints", "break": "breakpoints", "watchpoints": "breakpoints",
                "r": "registers"}
MOVES = ("cycle", "step", "stepi", "next", "nexti", "continue", "until", "finish", "reverse-cycle",
         "reverse-step", "reverse-stepi", "reverse-continue", "restart")
LAYOUTS = ("auto", "asm", "regs", "full")
