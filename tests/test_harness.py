"""The stage test bench: one real stage program, stubs on the other processors; on every engine
(`engine_name`, tests/conftest.py)."""

from __future__ import annotations

from netsushisen.asm.assembler import assemble_text
from netsushisen.emulator.harness import encode_message, run_stage, split_words
from netsushisen.isa.config import load_config
from netsushisen.isa.ring import parse_header
from netsushisen.isa.words import FP32

# An IC program that answers each 3-word message with NEXT(slot) to OS and, when the slot is odd,
# also HIT-like (slot, t * 2) to SC: exercises IC -> OS forwarding through SC's CMU.
IC_ECHO = """
.proc ic
loop:   recv r1, ring            # header
        recv r2, ring            # slot
        recv r3, ring            # list pointer (unused)
        recv r4, ring            # t_exit
        li r5, (4 << HDR_TAG_SHIFT) | (1 << HDR_CLS_SHIFT) | (DEST_OS << HDR_DEST_SHIFT) | 1
        send ring, r5
        send ring, r2
        andi r6, r2, 1
        beqz r6, loop
        { li r5, (6 << HDR_TAG_SHIFT) | (DEST_SC << HDR_DEST_SHIFT) | 2 ; fadd r7, r4, r4 }
        send ring, r5
        send ring, r2
        send ring, r7
        j loop
"""


def test_ic_alone_with_stubs(engine_name):
    config = load_config(None, [])
    msgs = [encode_message(FP32, "ic", 3, [slot, 100 + slot, 0.5 + slot]) for slot in range(4)]
    run = run_stage("ic", assemble_text(IC_ECHO), msgs, config, engine=engine_name)
    assert run.result.status == "finished"
    to_os = run.received["os"]
    assert [parse_header(m[0]).tag for m in to_os] == [4, 4, 4, 4]
    assert [FP32.to_int(m[1]) for m in to_os] == [0, 1, 2, 3]
    to_sc = run.received["sc"]
    assert [(FP32.to_int(m[1]), float(FP32.to_float(m[2]))) for m in to_sc] == [(1, 3.0), (3, 7.0)]
    assert run.statistics()["processors"]["pe0.ic"]["bundles"] > 0


def test_split_words_keeps_a_cut_off_tail():
    words = encode_message(FP32, "os", 1, [1, 2]) + encode_message(FP32, "os", 1, [3, 4, 5])[:2]
    assert [len(m) for m in split_words(words)] == [3, 2]
