"""Every command of `netsushisen` (alias `nss`), one module each, as pbrt-v4 keeps its commands
in cmd/: each module's docstring is the command's description, `configure(parser)` adds its
options and `run(args) -> int` does the work. `netsushisen/cli.py` routes to them; the options
several commands share (-D, --set and the config shorthands, --res, --engine, programs and
image) come from `netsushisen/options.py`, so they mean and check the same everywhere.

    asm      assemble a stage kernel              disasm   object file back to source
    isa      the ISA reference                    scene    inspect a scene
    golden   render with the golden model         run      run programs on the machine
    config   show or check the configuration      render   render a scene on the machine
    debug    the step debugger                    report   ILP, stall, memory reports
    paper    the paper's tables and figures       accuracy what accuracy costs, per knob
    numerics numerical stability report

A command only parses, checks and prints: the work is done by the layers below it (asm/, isa/,
host/, emulator/ through its engine interface, debugger/, reports/, netsushisen/pipeline.py,
netsushisen/accuracy.py, netsushisen/numerics.py).
"""
