"""Set-associative caches (ic_memory.cache_ways / sc_memory.cache_ways: 1, 2, 4, 8 ways, LRU;
emulator/cacherule.py), worked by hand on every engine (`engine_name`).

fp32, blocks of 64 bytes = 16 words: word address 16·b is in block b. A miss holds issue for
t_g = 8 cycles (7 charged to cache_miss), a hit t_c = 2 (1 charged to cache_hit).
"""

from __future__ import annotations

import random
from collections import OrderedDict

import pytest

from netsushisen.asm.assembler import assemble_text
from netsushisen.emulator.harness import ProcessorView, run_machine
from netsushisen.emulator.memories import Cache
from netsushisen.isa.errors import ConfigError
from netsushisen.isa.config import load_config
from netsushisen.isa.images import image_from_json

ICGM = [float(i) for i in range(16 * 6)]


def _program(blocks: list[int]) -> str:
    return "\n".join(f"ldg r{1 + k % 9}, [r0 + {16 * b + k % 3}]" for k, b in enumerate(blocks)) \
        + "\nhalt\n"


def _run(engine, blocks, ways, cache_bytes):
    sets = [f"ic_memory.cache_ways={ways}", f"ic_memory.cache_bytes={cache_bytes}"]
    e = run_machine(engine, load_config(None, sets),
                    {"ic": assemble_text(_program(blocks), proc="ic")},
                    image_from_json({"icgm": ICGM}), max_cycles=10_000)
    assert e.result().status == "halted"
    return e


LRU_NOT_FIFO = [0, 2, 0, 2, 0, 4, 0, 2]
"""2 ways, 1 set: m m h h h m(4 evicts 2, the least recent) h(0 stayed: FIFO would have
evicted it) m → 4 hits, 4 misses, set [2, 0]. Direct-mapped with the same 128 bytes (2 sets):
blocks 0, 2, 4 all map to set 0 and evict each other → 8 misses."""


@pytest.mark.parametrize("ways, hits, tags", [(2, 4, [2, 0]), (1, 0, [1, -1])])
def test_two_ways_keep_the_recently_used_block(engine_name, ways, hits, tags):
    e = _run(engine_name, LRU_NOT_FIFO, ways, 128)
    mem = e.statistics()["memory"]["pe0.ic"]
    assert mem["cache"] == {"accesses": 8, "hits": hits, "misses": 8 - hits,
                            "sets": 2 // ways, "ways": ways, "block_bytes": 64}
    ic = ProcessorView(e, "pe0.ic")
    assert ic.stalls == {"cache_miss": 7 * (8 - hits), **({"cache_hit": hits} if hits else {})}
    assert ic.cycles == 8 * (8 - hits) + 2 * hits + 1
    # 2 ways: set 0 holds [MRU, LRU] tags (block // 1 set); direct-mapped: set 0 tag 1
    # (block 2 // 2 sets), set 1 never used
    assert e.machine.pes[0].memories["ic"].cache.tags.tolist() == tags


EVICT = [0, 1, 2, 3, 0, 4, 1, 0, 3, 2]


@pytest.mark.parametrize("ways, cache_bytes, hits", [
    (1, 256, 4),  # 4 sets: b4 evicts b0 (set 0), then b0 misses; 1, 3, 2 stay
    (2, 256, 4),  # 2 sets of 2: b0, b1, b0, b3 hit; b4 evicts b2 (LRU of set 0), b2 misses last
    (4, 256, 3),  # 1 set of 4: b4 evicts b1, b1 evicts b2, b2 evicts b4 — 3 hits (b0, b0, b3)
    (8, 512, 5),  # 1 set of 8: nothing is evicted; the five first touches miss
])
def test_hits_and_misses_worked_by_hand(engine_name, ways, cache_bytes, hits):
    e = _run(engine_name, EVICT, ways, cache_bytes)
    c = e.statistics()["memory"]["pe0.ic"]["cache"]
    assert (c["hits"], c["misses"], c["ways"], c["sets"]) == \
        (hits, 10 - hits, ways, cache_bytes // 64 // ways)


def _lru_oracle(blocks, sets, ways):
    """An independent LRU model: per set an ordered dict of tags, most recent last."""
    lines = [OrderedDict() for _ in range(sets)]
    out = []
    for b in blocks:
        s, t = b % sets, b // sets
        hit = t in lines[s]
        if hit:
            lines[s].move_to_end(t)
        else:
            if len(lines[s]) == ways:
                lines[s].popitem(last=False)
            lines[s][t] = None
        out.append(hit)
    return out


@pytest.mark.parametrize("ways", [1, 2, 4, 8])
def test_the_rule_is_lru(ways):
    rng = random.Random(ways)
    cache = Cache("ic cache", 1024, 64, 4, ways)
    blocks = [rng.randrange(64) for _ in range(3000)]
    got = [cache.access(16 * b + rng.randrange(16))[0] for b in blocks]
    assert got == _lru_oracle(blocks, 16 // ways, ways)
    assert cache.hits == sum(got) and cache.misses == len(got) - sum(got)


@pytest.mark.parametrize("sets, message", [
    (["ic_memory.cache_ways=3"], "ic_memory.cache_ways must be 1, 2, 4 or 8, got 3"),
    (["sc_memory.cache_ways=16"], "sc_memory.cache_ways"),
    (["ic_memory.cache_ways=0"], "ic_memory.cache_ways"),
    (["ic_memory.cache_ways=4", "ic_memory.cache_bytes=128"],
     "ic_memory.cache_bytes (128) must be a multiple of block_bytes × cache_ways (64 × 4"),
])
def test_bad_ways_are_refused(sets, message):
    with pytest.raises(ConfigError) as err:
        load_config(None, sets)
    assert message in err.value.format()


def test_a_share_rounds_down_to_whole_sets():
    from netsushisen.isa.regions import cache_bytes

    mc = load_config(None, ["ic_memory.cache_share=0.5", "ic_memory.cache_ways=4"]).ic_memory
    assert cache_bytes(mc, 300, 4) == 512  # 600 bytes → one set of 4 × 64
    mc1 = load_config(None, ["ic_memory.cache_share=0.5"]).ic_memory
    assert cache_bytes(mc1, 300, 4) == 576  # direct-mapped: whole blocks, as before
