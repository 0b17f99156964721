"""Memories: resident vs cache vs global timing, the direct-mapped cache, counters, faults.

Timing rule T6 (core.py): a load with access time T issued in c holds issue until c + T and its
result is readable then; the T − 1 held cycles are charged to local / resident / cache_hit /
cache_miss. Default t_r = 1, t_c = 2, t_g = 8; blocks of 64 bytes = 16 words in fp32.

The machine tests run once per engine (`engine_name`, tests/conftest.py) and read counters,
registers and memories through the engine interface; the Cache and RegionMap unit tests use the
reference engine's classes directly.
"""

from __future__ import annotations

import numpy as np
import pytest

from netsushisen.asm.assembler import assemble_text
from netsushisen.isa.images import image_from_json
from netsushisen.emulator.engine import make_engine
from netsushisen.emulator.harness import ProcessorView, run_machine
from netsushisen.emulator.memories import Cache, Region, RegionMap
from netsushisen.isa.config import load_config

ICGM = [float(i) + 0.5 for i in range(64)]


def run(engine, sets=(), image=None, **sources):
    programs = {proc: assemble_text(src, proc=proc) for proc, src in sources.items()}
    e = run_machine(engine, load_config(None, list(sets)), programs, image_from_json(image or {}),
                    max_cycles=10_000)
    return e, e.result()


def memory_stats(e, proc="ic", pe=0) -> dict:
    return e.statistics()["memory"][f"pe{pe}.{proc}"]


CACHE_PROGRAM = """
    ldg r1, [r0 + 0]     # c0 miss: held c1..c7 (7 cache_miss), r1 ready at 8
    fadd r7, r1, r1      # c8: the loaded value is ready, no operand stall
    ldg r2, [r0 + 1]     # c9 hit (same 64-byte block): held c10 (1 cache_hit)
    ldg r3, [r0 + 32]    # c11: byte 128 -> block 2 -> set 0 of 2, tag 1: miss, held c12..c18
    ldg r4, [r0 + 2]     # c19: block 0 was evicted from set 0: miss again, held c20..c26
    ldg r5, [r0 + 16]    # c27: block 1 -> set 1: miss, held c28..c34
    ldr r6, [r0 + 0]     # c35: resident, t_r = 1: no stall
    halt                 # c36
"""


def test_cache_hit_miss_and_conflict_in_a_direct_mapped_set(engine_name):
    m, r = run(engine_name, sets=["ic_memory.cache_bytes=128"],  # 2 sets of 64 bytes
               image={"icgm": ICGM, "ic.resident": [7.25]}, ic=CACHE_PROGRAM)
    ic = ProcessorView(m, "pe0.ic")
    assert r.status == "halted"
    assert ic.cycles == 37
    assert ic.stalls == {"cache_miss": 28, "cache_hit": 1}
    assert ic.stalls_by_pc[0] == {"cache_miss": 7} and ic.stalls_by_pc[2] == {"cache_hit": 1}
    assert [ic.float(i) for i in (1, 2, 3, 4, 5, 6, 7)] == \
        [0.5, 1.5, 32.5, 2.5, 16.5, 7.25, 1.0]
    st = memory_stats(m)
    assert st["cache"]["accesses"] == 5 and st["cache"]["hits"] == 1 and st["cache"]["misses"] == 4
    assert st["global"]["accesses"] == 4 and st["resident"]["accesses"] == 1


def test_resident_cache_global_scale_with_t_r(engine_name):
    # t_r = 3, t_c = 6, t_g = 24: ldr holds 2, a miss 23, a hit 5, local ld 2.
    m, _ = run(engine_name, sets=["ic_memory.t_r=3", "ic_memory.t_c=6", "ic_memory.t_g=24"],
               image={"icgm": ICGM, "ic.resident": [1.0]}, ic="""
        ldr r1, [r0]        # c0, held c1..c2
        ldg r2, [r0]        # c3, held c4..c26
        ldg r3, [r0 + 1]    # c27, held c28..c32
        ld r4, [r0]         # c33, held c34..c35 (IC local memory: t_r)
        halt                # c36
    """)
    ic = ProcessorView(m, "pe0.ic")
    assert ic.stalls == {"resident": 2, "cache_miss": 23, "cache_hit": 5, "local": 2}
    assert ic.cycles == 37


def test_os_local_load_time_is_the_ld_latency(engine_name):
    m, _ = run(engine_name, sets=["os.latency.ld=4"], image={"os.local": [5, 6]}, os="""
        ld r1, [r0 + 1]     # c0, held c1..c3 (local)
        addi r2, r1, 1      # c4
        halt                # c5
    """)
    os_ = ProcessorView(m, "pe0.os")
    assert os_.stalls == {"local": 3} and os_.cycles == 6 and os_.raw(2) == 7


def test_block_size_counts_bytes_so_precision_changes_hits(engine_name):
    # word 8 is byte 32 in fp32 (block 0: hit) but byte 64 in fp64 (block 1: miss)
    src = """
        ldg r1, [r0]
        ldg r2, [r0 + 8]
        halt
    """
    m32, _ = run(engine_name, image={"icgm": ICGM}, ic=src)
    m64, _ = run(engine_name, sets=["precision=fp64"], image={"icgm": ICGM}, ic=src)
    assert memory_stats(m32)["cache"]["hits"] == 1
    assert memory_stats(m64)["cache"]["hits"] == 0
    assert ProcessorView(m64, "pe0.ic").float(2) == 8.5


def test_no_cache_means_every_access_misses(engine_name):
    m, _ = run(engine_name, sets=["ic_memory.cache_bytes=0"], image={"icgm": ICGM}, ic="""
        ldg r1, [r0]
        ldg r2, [r0]
        halt
    """)
    assert memory_stats(m)["cache"]["misses"] == 2
    assert ProcessorView(m, "pe0.ic").stalls == {"cache_miss": 14}


def test_store_then_load_and_same_bundle_reads_old_value(engine_name):
    m, _ = run(engine_name, os="""
        li r1, 9                            # c0
        { st r1, [r0 + 3] ; ld r2, [r0 + 3] }   # c1: the load reads before the store writes
        ld r3, [r0 + 3]                     # c2
        halt
    """)
    os_ = ProcessorView(m, "pe0.os")
    assert (os_.raw(2), os_.raw(3)) == (0, 9)
    assert int(m.memory("pe0.os", "local")[3]) == 9


def test_program_data_loaded_at_local_zero_and_image_overrides(engine_name):
    prog = assemble_text("""
        ld r1, [r0 + 0]
        ld r2, [r0 + 1]
        halt
        .data
        .word 11, 22
    """, proc="sc")
    m = run_machine(engine_name, load_config(), {"sc": prog},
                    image_from_json({"sc.local": {"at": 1, "words": [33]}}))
    sc = ProcessorView(m, "pe0.sc")
    assert (sc.raw(1), sc.raw(2)) == (11, 33)


def test_region_and_primitive_counters(engine_name):
    image = {"icgm": ICGM, "ic.resident": [0.0] * 8,
             "regions": {"ic.global": [[0, 16, "primitive_list", None], [16, 17, "shape_data", 5],
                                       [32, 33, "shape_data", 7]],
                         "ic.resident": [[0, 1, "shape_data", 5]]}}
    m, _ = run(engine_name, image=image, ic="""
        ldg r1, [r0 + 0]
        ldg r1, [r0 + 1]
        ldg r2, [r0 + 16]
        ldg r2, [r0 + 32]
        ldg r2, [r0 + 32]
        ldr r3, [r0 + 0]
        ldr r3, [r0 + 1]
        halt
    """)
    st = memory_stats(m)
    assert st["regions"]["global.primitive_list"] == {"accesses": 2, "hits": 1, "misses": 1}
    assert st["regions"]["global.shape_data"] == {"accesses": 3, "hits": 1, "misses": 2}
    assert st["regions"]["resident.shape_data"] == {"accesses": 1}
    assert st["primitives"] == {"5": 2, "7": 2}


def test_region_map_interface():
    rm = RegionMap([Region(10, 20, "shape_data", 3), Region(0, 10, "primitive_list")])
    assert rm.lookup(0).name == "primitive_list" and rm.lookup(19).primitive == 3
    assert rm.lookup(20) is None and rm.lookup(-1) is None
    with pytest.raises(ValueError):
        RegionMap([Region(0, 10, "a"), Region(5, 12, "b")])


def test_cache_locate():
    c = Cache("t", cache_bytes=256, block_bytes=64, word_bytes=4)  # 4 sets
    assert c.locate(0) == (0, 0) and c.locate(16) == (1, 0) and c.locate(64) == (0, 1)
    assert c.access(64) == (False, 0) and c.access(65) == (True, 0) and c.access(0) == (False, 0)
    assert c.probe(1) and not c.probe(64)


def test_cache_share_sizes_from_the_global_image(engine_name):
    config = load_config(None, ["ic_memory.cache_share=0.5", "ic_memory.resident_share=0.25"])
    m = make_engine(engine_name, config,
                    {"ic": assemble_text("halt", proc="ic")}, image_from_json({"icgm": [0] * 256}))
    mem = memory_stats(m)
    assert mem["cache"]["sets"] == 8  # 0.5 * 256 words * 4 bytes = 512 bytes = 8 blocks
    assert mem["resident"]["words"] == 64


@pytest.mark.parametrize("src, what", [
    ("ldg r1, [r0 + 64]\nhalt", "ICGM address 64 is outside 0..63"),
    ("li r2, -1\nldr r1, [r2]\nhalt", "resident memory address -1"),
    ("li r2, 70000\nst r2, [r2]\nhalt", "local memory address 70000"),
])
def test_access_outside_a_memory_is_a_located_fault(src, what, engine_name):
    m, r = run(engine_name, image={"icgm": ICGM}, ic=src)
    assert r.status == "fault" and r.exit_code == 2
    text = r.error.format()
    assert what in text and "pe0.ic" in text and "cycle" in text


def test_fault_names_label_and_offset(engine_name):
    m, r = run(engine_name, image={"icgm": ICGM}, ic="""
    start:
        nop
        ldg r1, [r0 + 100]
        halt
    """)
    assert "pe0.ic pc 1 (start+1) cycle 1" in r.error.format()


def test_running_off_the_program_is_a_fault(engine_name):
    # the store before the end has happened: the machine is left as the fault found it
    m, r = run(engine_name, ic="li r1, 7\nst r1, [r0 + 5]\nnop")
    assert r.status == "fault" and "pc 3 is outside the program (0..2)" in r.error.format()
    local = m.memory("pe0.ic", "local")
    assert len(local) == 1 << 16 and int(local[5]) == 7 and not local[:5].any()
