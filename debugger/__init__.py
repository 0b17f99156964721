"""The step debugger (`netsushisen debug`, docs/debugger.md): a session over one machine —
stepping by source lines, bundles or cycles, breakpoints, watchpoints, `set`, exact reverse execution — and
its command language, expressions, screen and terminal front end.

    session.py      `Session`; the machine factories (`ProgramsFactory`, `SceneFactory`)
    breakpoints.py  breakpoints and watchpoints (break, tbreak, watch, rwatch, awatch, enable,
                    disable, condition, ignore): how a cycle makes them fire
    commands.py     the command language (`Commands.execute(line) -> Outcome`)
    breakcommands.py  its breakpoint, watchpoint and display commands (a mixin)
    source.py       its source-line commands: `list`, `info line`, `info symbol`, `info loop`,
                    `x/Ni`
    help.py         usage, help texts, aliases
    expressions.py  expressions, places (registers, memory words, PCs), locations; `.reg` names
    reverse.py      checkpoints, replay, reverse-cycle / -step / -stepi / -continue
    fastforward.py  `--fast-forward`: the compiled engine runs to a cycle or a location first
    state.py        `freeze` / `thaw` (checkpoints) and `state_dump` (the canonical state dump)
    view.py         the rich panels of the screen
    registers.py    its registers panel, packed register cells, `info registers`
    layout.py       the screen: which panels show, sized to the terminal (`layout`)
    frontend.py     the batch and interactive front ends (prompt, history, tab completion,
                    gdb's pager)

Unlike every other reader of the machine (the render pipeline, reports, benchmarks), the
debugger does not go through the engine interface (emulator/engine.py): it knows the reference
engine's internals and steps the reference `Machine` (emulator/machine.py) directly. It has to:
its screen shows what the interface deliberately leaves out — each core's scoreboard and
results in flight, the bundle issued or the stall cause of the last cycle, every FIFO and CMU
lock, the cache set touched last — and reverse execution checkpoints and restores the whole
mutable state of the machine (state.py pickles the same parts `Machine.snapshot` copies) and
replays cycle by cycle. Widening the engine interface to all of that would make every engine
model the reference engine's objects; instead the reference engine is the one the debugger
steps (an engine that computes elsewhere writes its state back into a reference `Machine`,
which the debugger can then take over: `--fast-forward` does exactly that, fastforward.py). The
debugger has no timing rules of its own: every cycle it shows is one `Machine.step()`.
"""
