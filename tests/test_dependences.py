"""The dependence graph (asm/dependences.py): each kind of edge, its latency from the configuration
being assembled for, and the loop-carried edges of a loop body."""

from __future__ import annotations

from netsushisen.asm.assembler import assemble_text
from netsushisen.asm.dependences import dependences, result_latency
from netsushisen.isa.config import MachineConfig, load_config
from netsushisen.isa.processors import PROCESSORS

IC = PROCESSORS["ic"]


def ops_of(text: str, proc: str = "ic"):
    return [op for bundle in assemble_text(text, proc=proc).bundles for op in bundle]


def edges(text: str, config: MachineConfig | None = None, loop: bool = False, proc: str = "ic"):
    g = dependences(ops_of(text, proc), PROCESSORS[proc], config or MachineConfig(), loop=loop)
    return {(e.src, e.dst, e.kind, e.latency, e.distance) for e in g.edges}, g


def test_true_anti_output_with_latencies_from_the_config():
    text = "fmul r1, r2, r3\nfadd r4, r1, r1\nfadd r1, r5, r5\nhalt\n"
    found, _ = edges(text)
    assert (0, 1, "true", 3, 0) in found
    assert (1, 2, "anti", 0, 0) in found  # the write may share the reader's bundle
    assert (0, 2, "output", 3, 0) in found
    slow, _ = edges(text, load_config(None, ["ic.latency.fmul=7"]))
    assert (0, 1, "true", 7, 0) in slow and (0, 2, "output", 7, 0) in slow


def test_load_latency_is_the_memory_access_time():
    cfg = load_config(None, ["ic_memory.t_r=3", "ic_memory.t_c=5"])
    ops = ops_of("ldr r1, [r2]\nldg r3, [r2]\nld r4, [r2]\nhalt\n")
    assert [result_latency(op, IC, cfg) for op in ops[:3]] == [3, 5, 3]


def test_local_memory_alias_rules():
    # same base, same value, different offsets: independent; same offset: ordered
    found, _ = edges("st r1, [r2 + 0]\nld r3, [r2 + 1]\nld r4, [r2 + 0]\nst r5, [r2 + 0]\nhalt\n")
    mem = {(s, d, lat) for s, d, k, lat, _ in found if k == "memory"}
    assert (0, 1, 1) not in mem
    assert (0, 2, 1) in mem  # store -> load of the same word
    assert (2, 3, 0) in mem  # load -> store may share a bundle
    assert (0, 3, 0) in mem  # store -> store in bundle order
    # the base changes between them: may alias
    found, _ = edges("st r1, [r2 + 0]\naddi r2, r2, 1\nld r3, [r2 + 1]\nhalt\n")
    assert any(k == "memory" and (s, d) == (0, 2) for s, d, k, _, _ in found)
    # resident loads never conflict with local stores
    found, _ = edges("st r1, [r2]\nldr r3, [r2]\nhalt\n")
    assert not any(k == "memory" for _, _, k, _, _ in found)


def test_fifo_operations_chain_in_order_and_control_ends_the_block():
    found, g = edges("recv r1, ring\nadd r5, r6, r7\nsend ring, r2\npoll r3, ring\nbeqz r3, 0\n")
    assert (0, 2, "fifo", 1, 0) in found and (2, 3, "fifo", 1, 0) in found
    assert all((i, 4, "control", 0, 0) in found for i in range(4))


def test_loop_carried_edges_and_heights():
    body = "loop:\nldr r2, [r1]\nfmul r4, r2, r2\nfadd r10, r10, r4\naddi r1, r1, 1\nblt r1, r9, loop\n"
    found, g = edges(body, loop=True)
    assert (2, 2, "true", 2, 1) in found  # the sum's recurrence
    assert (3, 3, "true", 1, 1) in found  # the induction
    assert (0, 3, "anti", 0, 0) in found  # ldr reads r1 before addi writes it
    assert (3, 0, "true", 1, 1) in found  # next iteration's ldr reads the new r1
    # heights: ldr -> fmul (1) -> fadd (3) -> its own latency 2
    assert g.heights[0] == 1 + 3 + 2
    plain, _ = edges(body)
    assert not any(d for *_, d in plain)
