"""The three stage processors of a PE (the paper's OS, IC and SC; docs/isa.md), as data.

| processor | kind       | units                 | register-file ports |
| OS        | VLIW       | 2 integer + 2 FP      | 5 read, 2 write     |
| IC        | VLIW       | 1 integer + 3 FP      | 6 read, 3 write     |
| SC        | sequential | 1 general-purpose     | 3 read, 1 write (ours: enough for any one operation) |

Each has one unified multiport register file (integer and FP values share it, as in the paper),
64 registers of one machine word each: r0 reads as zero and ignores writes; r63 is the link
register `lr` that `call` writes and `ret` reads. Reads of r0 and writes to it use no port.

The integer unit of a VLIW is also its memory, communication and branch unit: loads, stores,
FIFO sends/receives and control transfers occupy an integer slot. SC's one general unit does
everything, one operation per instruction.
"""

from __future__ import annotations

from dataclasses import dataclass

N_REGISTERS = 64
ZERO_REGISTER = 0
LINK_REGISTER = 63
REGISTER_ALIASES = {"zero": ZERO_REGISTER, "lr": LINK_REGISTER}


@dataclass(frozen=True)
class Processor:
    name: str  # "os", "ic", "sc"
    title: str
    vliw: bool
    units: dict[str, int]
    """Functional units by class ('int', 'fp'; SC: 'gen')."""
    unit_of_class: dict[str, str]
    """Which unit executes an opcode of each unit class (SC maps 'int' and 'fp' to 'gen')."""
    read_ports: int
    write_ports: int
    memories: tuple[str, ...]
    """Memory spaces its loads and stores reach: 'local', 'resident', 'global' (through cache)."""
    recv_ports: tuple[str, ...]
    """FIFOs it receives from: 'ring' (its CMU), 'host' (primary rays from DIS, OS only)."""
    send_ports: tuple[str, ...]
    """FIFOs it sends to: 'ring' (its CMU, routed by the message header), 'col' (SC → COL)."""
    registers: int = N_REGISTERS

    @property
    def issue_width(self) -> int:
        return sum(self.units.values())

    def unit(self, unit_class: str) -> str:
        return self.unit_of_class[unit_class]


OS = Processor(
    name="os", title="OS — object search", vliw=True,
    units={"int": 2, "fp": 2}, unit_of_class={"int": "int", "fp": "fp"},
    read_ports=5, write_ports=2,
    memories=("local",), recv_ports=("host", "ring"), send_ports=("ring",),
)
IC = Processor(
    name="ic", title="IC — intersection calculation", vliw=True,
    units={"int": 1, "fp": 3}, unit_of_class={"int": "int", "fp": "fp"},
    read_ports=6, write_ports=3,
    memories=("local", "resident", "global"), recv_ports=("ring",), send_ports=("ring",),
)
SC = Processor(
    name="sc", title="SC — shading calculation", vliw=False,
    units={"gen": 1}, unit_of_class={"int": "gen", "fp": "gen"},
    read_ports=3, write_ports=1,
    memories=("local", "resident", "global"), recv_ports=("ring",), send_ports=("ring", "col"),
)

PROCESSORS: dict[str, Processor] = {p.name: p for p in (OS, IC, SC)}
STAGES = ("os", "ic", "sc")  # ring order: OS → IC → SC → OS


def register_name(index: int) -> str:
    return {ZERO_REGISTER: "r0", LINK_REGISTER: "lr"}.get(index, f"r{index}")
