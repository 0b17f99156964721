"""The disassembler: a Program back to source that reassembles to the identical program.

Labels come back from the symbol table (branch targets print as the label at the address, or
`label+N` from the nearest one before it: `listing.target_names`); constants and
aliases do not survive assembly, so numbers print as themselves; registers too, unless `names`
asks for the `.reg` names the object file records (`Program.reg_names`): then each name's `.reg`
line stands before the bundle its scope starts at (after an `.unreg` of the name's earlier
binding) and operands use the name the source used
(asm/regnames.py), which reassembles to the identical program. Floats print with `repr`, which
round-trips every double exactly.
"""

from __future__ import annotations

from netsushisen.asm.listing import target_names
from netsushisen.asm.objects import Program, format_float
from netsushisen.asm.regnames import register_names


def disassemble(program: Program, names: bool = False) -> str:
    labels = target_names(program)
    table = register_names(program)
    starts: dict[int, list[str]] = {}
    if names:
        bound: set[str] = set()
        for r in sorted(program.reg_names, key=lambda r: r.start):
            if r.name in bound:  # a name is bound once per scope: end the earlier binding
                starts.setdefault(r.start, []).append(f".unreg {r.name}")
            bound.add(r.name)
            starts.setdefault(r.start, []).append(f".reg {r.name} = r{r.reg}")
    text_labels: dict[int, list[str]] = {}
    data_labels: dict[int, list[str]] = {}
    for name, (section, addr) in sorted(program.labels.items()):
        (text_labels if section == "text" else data_labels).setdefault(addr, []).append(name)
    out = [f".proc {program.proc}"]
    if program.data or data_labels:
        out.append(".data")
        for addr, (kind, value) in enumerate(program.data):
            for name in data_labels.get(addr, []):
                out.append(f"{name}:")
            shown = format_float(value) if kind == "f" else str(value)
            out.append(f"    .{'float' if kind == 'f' else 'word'} {shown}")
        for name in data_labels.get(len(program.data), []):  # a label at the end of data
            out.append(f"{name}:")
        out.append(".text")
    for addr, bundle in enumerate(program.bundles):
        out += starts.get(addr, [])
        for name in text_labels.get(addr, []):
            out.append(f"{name}:")
        regs = table.names(addr) if names else None
        if len(bundle) == 1:
            out.append(f"    {bundle[0].format(labels, regs)}")
        else:
            out.append("    { " + " ; ".join(op.format(labels, regs) for op in bundle) + " }")
    for name in text_labels.get(len(program.bundles), []):
        out.append(f"{name}:")
    return "\n".join(out) + "\n"
