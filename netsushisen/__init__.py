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

The Python API (`netsushisen/api.py`, docs/api.md) is this package's public surface, the names of
`__all__`; everything else is private. The names load on first use, so `import netsushisen` and
a command that needs none of them stay cheap:

    import netsushisen as nss
    r = nss.render("tetra", res=32, set={"ic.latency.fmul": 6})
    r.table("ilp")          # a pandas DataFrame with the columns of `report ilp --format csv`
"""

__version__ = "0.1.0"

__all__ = ["render", "golden", "run", "assemble", "scene", "Config", "load_stats", "Results",
           "NetsushisenError", "__version__"]


def __getattr__(name: str):
    """The API's names, imported on first use (PEP 562). `netsushisen.render` is the API's
    function (the render pipeline module is `netsushisen.pipeline`: no submodule may take an
    API name, or importing it would replace the function)."""
    if name == "NetsushisenError":
        from netsushisen.isa.errors import NetsushisenError
        return NetsushisenError
    if name in __all__:
        from netsushisen import api
        return getattr(api, name)
    raise AttributeError(f"module 'netsushisen' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(__all__)
