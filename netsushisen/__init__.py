"""netsushisen: a toolchain for the Netsushisen (熱視線) parallel ray-tracing machine (1992).

The package root is the top of the toolchain: the command dispatcher (`cli`) and the commands
(`commands/`, one module each) over one shared option layer (`options`), the render pipeline that
joins host and machine (`render`), and the diagnostics every tool reports bad input with
(`errors`). The other parts live in their own top-level folders, imported under this namespace:

    netsushisen.isa       the machine as data: processors, opcode table, memory and ring
                          parameters; memory images and database regions (host and machine)
    netsushisen.asm       Lark grammar, assembler, resource checker, listing, disassembler, objects
    netsushisen.emulator  the machine only: cores, memories, CMU ring, PEs, DIS, COL, statistics,
                          and the engine interface every reader of the machine goes through
    netsushisen.debugger  the step debugger (it steps the reference engine directly)
    netsushisen.kernels   the hand-written OS / IC / SC stage programs
    netsushisen.host      scenes (NFF, SPD generators), grid, databases, pre-pass, golden renderer
    netsushisen.reports   ILP, stall and memory reports; the paper's tables and figures

Data flows one way: scene → host → memory images → machine → statistics → reports.
"""

__version__ = "0.1.0"
