"""netsushisen: a toolchain for the Netsushisen (熱視線) parallel ray-tracing machine (1992).

The package root holds only what every part shares: the command line (`cli`) and the
diagnostics every tool reports bad input with (`errors`). The machine's parts live in the
design card's top-level folders, imported under this namespace:

    netsushisen.isa       the machine as data: processors, opcode table, memory and ring parameters
    netsushisen.asm       Lark grammar, assembler, resource checker, listing, disassembler, objects
    netsushisen.emulator  the cycle-accurate machine: cores, memories, CMU ring, PEs, DIS, COL
    netsushisen.kernels   the hand-written OS / IC / SC stage programs
    netsushisen.host      scenes (NFF, SPD generators), grid, databases, pre-pass, golden renderer
    netsushisen.reports   ILP, stall and memory reports; the paper's tables and figures
"""

__version__ = "0.1.0"
