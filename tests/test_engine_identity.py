"""The compiled engine is the reference engine, output for output (issue 11, items 2 and 8).

Three kinds of evidence, each comparing a `reference` run with a `compiled` run of the same input:

1. Renders through the command line (in-process): `render S --res R --engine compiled` and
   `--engine reference` write byte-identical statistics JSON, PNG images and hit-id arrays,
   and end with the same exit code and standard error. The default suite covers every axis at
   least once at a small size (4x4 to 8x8: the four paper scenes, 4 PEs, --generic, fp64,
   latency overrides, cache size, resident share, t_r/t_c/t_g, FIFO depth, link latency, buffer
   pool off, dynamic DIS, a cycle limit cutting a render short); `-m slow` runs the full matrix
   at 16x16 (scenes x PEs {1, 4} x {specialised, generic} x {fp32, fp64}, and every override on
   every scene).
2. Ends other than success through `run`: run-time faults (loads and stores outside a memory,
   PC outside the program, bad COL header, pixel outside the frame, a COL header on the ring),
   deadlocks (in a PE, of COL, with 2 PEs and dynamic DIS) and the cycle limit give the same
   exit code, the same report text (standard error and summary) and the same statistics file.
3. Random programs (hypothesis): small valid programs for OS, IC and SC built from the opcode
   table and the resource checker, random memory images and host streams, random
   configurations; both engines run them to a cycle limit and must agree on the status, exit
   code, error text, statistics, every processor's registers and PC, every memory, the frame
   and the hit ids. 50 examples by default (always the same), 400 more under `-m slow`.

A difference found here is a bug in the compiled engine: `--engine tandem` names its first
cycle.
"""

from __future__ import annotations

import itertools
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, note, settings
from hypothesis import strategies as st
from program_strategies import random_bundles

from netsushisen.asm.disasm import disassemble
from netsushisen.asm.objects import Op, Program
from netsushisen.emulator import stats as run_stats
from netsushisen.emulator.engine import engine_names, make_engine
from netsushisen.isa.errors import ConfigError, NetsushisenError
from netsushisen.isa.config import load_config
from netsushisen.isa.images import MemoryImage, Segment
from netsushisen.isa.opcodes import opcodes_for
from netsushisen.isa.processors import STAGES
from netsushisen.isa.regions import REGION_NAMES, Region
from netsushisen.isa.ring import make_header

assert "compiled" in engine_names(), "the compiled engine does not import (numba is a dependency)"

ENGINES = ("reference", "compiled")


def engine_neutral(text: str | bytes, engine: str) -> str:
    """Output with the engine's name taken out: `run.engine` in the statistics and the run
    summary's `, compiled engine` are the one place two engines' outputs differ by design."""
    text = text.decode() if isinstance(text, bytes) else text
    return (text.replace(f'"engine": "{engine}"', '"engine": "*"')
            .replace(f", {engine} engine", ", * engine"))
PAPER = ("tetra", "balls", "mount", "rings")


# ---------------------------------------------------------------------------------------------
# 1. Renders through the command line


@pytest.fixture
def render_pair(cli, tmp_path, monkeypatch):
    """`render_pair(scene, res, *args)`: run `render` once per engine and assert that the
    statistics JSON, the PNG and the ids are byte-identical and the exit codes and standard
    errors equal; returns (exit code, statistics JSON text).

    The kernels of a (defines, folder) pair are assembled once and shared by both runs (the
    assembler is most of a small render's time; the programs are only read by the engines)."""
    from netsushisen import pipeline

    assembled: dict = {}
    assemble = pipeline.assemble_kernels

    def cached(defines, kernel_dir=None, overrides=None, config=None):
        key = (tuple(sorted(defines.items())), str(kernel_dir),
               tuple(sorted((overrides or {}).items())),
               pipeline.schedule_key(config) if config else None)
        if key not in assembled:
            assembled[key] = assemble(defines, kernel_dir, overrides, config)
        return assembled[key]

    monkeypatch.setattr(pipeline, "assemble_kernels", cached)

    def run(scene: str, res: int, *args: str, code: int = 0) -> tuple[int, str]:
        outs = {}
        for engine in ENGINES:
            d = tmp_path / engine
            d.mkdir(exist_ok=True)
            got, _, err = cli("render", scene, "--res", res, *args, "--engine", engine,
                              "--quiet", "-o", d / "image.png", "--ids", d / "ids.npy",
                              "--json", d / "stats.json")
            outs[engine] = (got, err, engine_neutral((d / "stats.json").read_bytes(), engine),
                            *((d / f).read_bytes() for f in ("image.png", "ids.npy")))
        (rc, rerr, rjson, rpng, rids), (cc, cerr, cjson, cpng, cids) = outs.values()
        assert rc == code, rerr
        assert cc == rc and cerr == rerr
        if cjson != rjson:  # name the first differing line, not a 10,000-line diff
            lines = zip(rjson.splitlines(), cjson.splitlines())
            first = next(((i, a, b) for i, (a, b) in enumerate(lines) if a != b), None)
            pytest.fail(f"statistics differ (line, reference, compiled): {first}")
        assert cpng == rpng, "images differ"
        assert cids == rids, "hit ids differ"
        return rc, rjson

    return run


# (id, scene, res, extra arguments): every axis of the 16x16 matrix at least once, small
SMALL_RENDERS = [
    ("tetra", "tetra", 8, ()),
    ("balls", "balls", 4, ()),
    ("mount", "mount", 6, ()),
    ("rings", "rings", 4, ()),
    ("pes4", "balls", 4, ("--pes", "4")),
    ("generic", "tetra", 6, ("--generic",)),
    ("fp64", "mount", 4, ("--precision", "fp64")),
    ("fp64-generic-pes4", "rings", 4, ("--precision", "fp64", "--generic", "--pes", "4")),
    ("latencies", "tetra", 6, ("--set", "ic.latency.fdiv=20", "--set", "os.latency.fmul=5",
                               "--set", "sc.latency.fdiv=7", "--set", "ic.latency.fsqrt=3",
                               "--set", "os.taken_branch_penalty=2")),
    ("cache-size", "balls", 4, ("--set", "ic_memory.cache_bytes=512",
                                "--set", "sc_memory.cache_bytes=256",
                                "--set", "ic_memory.block_bytes=32")),
    ("cache-ways", "balls", 4, ("--precision", "fp64", "--set", "ic_memory.cache_ways=4",
                                "--set", "ic_memory.cache_bytes=1024",
                                "--set", "sc_memory.cache_ways=2",
                                "--set", "sc_memory.cache_bytes=512")),
    ("resident-share", "mount", 4, ("--set", "ic_memory.resident_share=0.1",
                                    "--set", "sc_memory.resident_share=0.5")),
    ("memory-times", "rings", 4, ("--set", "ic_memory.t_g=20", "--set", "ic_memory.t_c=3",
                                  "--set", "ic_memory.t_r=2", "--set", "sc_memory.t_g=13")),
    ("fifo-depth", "balls", 4, ("--set", "ring.fifo_depth=21")),
    ("link-latency", "tetra", 6, ("--set", "ring.link_latency=3",
                                  "--set", "ring.link_buffer_words=2")),
    ("no-buffer-pool", "mount", 4, ("--set", "ring.buffer_pool=false")),
    ("dis-dynamic", "tetra", 6, ("--pes", "3", "--set", "distribution=dynamic")),
]


@pytest.mark.parametrize("scene,res,args", [c[1:] for c in SMALL_RENDERS],
                         ids=[c[0] for c in SMALL_RENDERS])
def test_render_outputs_identical_small(render_pair, scene, res, args):
    _, stats = render_pair(scene, res, *args)
    assert '"status": "finished"' in stats


def test_render_cut_by_the_cycle_limit_identical(render_pair):
    """A render stopped by the cycle limit (max_cycles): exit 4, the same partial image, ids and counters."""
    render_pair("balls", 4, "--set", "max_cycles=30011", code=4)


OVERRIDES = {
    "latencies": ("--set", "ic.latency.fdiv=20", "--set", "os.latency.fmul=5",
                  "--set", "sc.latency.fdiv=7"),
    "cache-size": ("--set", "ic_memory.cache_bytes=1024", "--set", "sc_memory.cache_bytes=512"),
    "cache-ways": ("--set", "ic_memory.cache_ways=4", "--set", "ic_memory.cache_bytes=2048",
                   "--set", "sc_memory.cache_ways=8"),
    "resident-share": ("--set", "ic_memory.resident_share=0.1",),
    "t_g": ("--set", "ic_memory.t_g=20", "--set", "sc_memory.t_g=16"),
    "fifo-depth": ("--set", "ring.fifo_depth=21",),
    "link-latency": ("--set", "ring.link_latency=3",),
    "no-buffer-pool": ("--set", "ring.buffer_pool=false",),
    "dis-dynamic": ("--pes", "4", "--set", "distribution=dynamic"),
}

MATRIX_16 = [pytest.param(scene, (*("--pes", str(pes)), *(("--generic",) if generic else ()),
                                  "--precision", precision),
                          id=f"{scene}-pes{pes}-{'generic' if generic else 'special'}-{precision}")
             for scene, pes, generic, precision in itertools.product(
                 PAPER, (1, 4), (False, True), ("fp32", "fp64"))]
MATRIX_16 += [pytest.param(scene, args, id=f"{scene}-{name}")
              for scene in PAPER for name, args in OVERRIDES.items()]


@pytest.mark.slow
@pytest.mark.parametrize("scene,args", MATRIX_16)
def test_render_outputs_identical_16(render_pair, scene, args):
    """The acceptance matrix at 16x16."""
    _, stats = render_pair(scene, 16, *args)
    assert '"status": "finished"' in stats


# ---------------------------------------------------------------------------------------------
# 2. Faults, deadlocks and the cycle limit through `run`


@pytest.fixture
def run_pair(cli, tmp_path):
    """`run_pair(sources, *args)`: write the stage sources, `run` them once per engine and
    assert the same exit code, summary, standard error and statistics file; returns
    (exit code, standard error)."""

    def run(sources: dict[str, str], *args: str) -> tuple[int, str]:
        argv = []
        for stage, text in sources.items():
            (tmp_path / f"{stage}.s").write_text(text)
            argv += [f"--{stage}", tmp_path / f"{stage}.s"]
        outs = []
        for engine in ENGINES:
            js, frame = tmp_path / f"{engine}.json", tmp_path / f"{engine}.npy"
            code, out, err = cli("run", *argv, *args, "--json", js, "--frame", frame,
                                 "--engine", engine)
            outs.append((code, engine_neutral(out, engine), err,
                         engine_neutral(js.read_bytes(), engine), frame.read_bytes()))
        (code, out, err, js, frame), other = outs
        assert "Traceback" not in err and "internal error" not in err
        assert other[0] == code, (other[2], err)
        assert other[2] == err
        assert other[1] == out
        assert other[3] == js, "statistics differ"
        assert other[4] == frame, "frame buffers differ"
        return code, err

    return run


COL_PIXEL = make_header(4, 3)

FAULTS = {
    "os-ld-outside-local": ({"os": "start: nop\n ld r1, [r0 + 70000]\n halt\n"}, (),
                            "local memory address 70000 is outside"),
    "os-st-outside-local": ({"os": " li r2, 5\n st r2, [r2 - 9]\n halt\n"}, (), "local memory address -4"),
    "ic-ldr-outside-resident": ({"ic": " nop\n nop\n ldr r1, [r0 + 5000]\n halt\n"}, (),
                                "resident memory address 5000 is outside 0..2047"),
    "ic-ldg-outside-icgm": ({"ic": "start: nop\n ldg r1, [r0 + 99]\n halt\n"}, (),
                            "ICGM address 99"),
    "sc-ldg-outside-scgm": ({"sc": " li r3, 7\n ldg r1, [r3 + 1]\n halt\n"}, (),
                            "SCGM address 8"),
    "sc-ld-small-local": ({"sc": " ld r1, [r0 + 64]\n halt\n"}, ("--set", "sc.local_words=64"),
                          "local memory address 64 is outside 0..63"),
    "pc-off-the-end": ({"ic": "start: li r1, 1\n addi r1, r1, 2\n"}, (),
                       "is outside the program"),
    "pc-jr-outside": ({"os": " li r1, 1000\n jr r1\n halt\n"}, (), "pc 1000 is outside"),
    "col-bad-header": ({"sc": f" li r1, {make_header(3, 3)}\n send col, r1\n halt\n"},
                       ("--set", "ring.deadlock_cycles=50"), "COL takes pixel messages"),
    "col-pixel-outside-frame": ({"sc": f" li r1, {COL_PIXEL}\n send col, r1\n li r2, 99\n"
                                       " send col, r2\n send col, r0\n send col, r0\n"
                                       " send col, r0\n halt\n"}, (), "outside the 0x0 frame"),
    "col-header-on-ring": ({"sc": f" li r1, {COL_PIXEL}\n send ring, r1\n halt\n"}, (),
                           "COL sent on the ring"),
    "fault-in-pe1": ({"ic": " li r1, 3\n ldg r2, [r1 + 40]\n halt\n"}, ("--pes", "2"),
                     "ICGM address 43"),
    # OS and SC wait on the ring the whole run (the compiled engine lets them sleep): the cycle
    # of IC's fault counts for the OS, stepped before IC, and not for the SC, stepped after it
    "fault-beside-waiting-processors": ({"os": " recv r1, ring\n halt\n",
                                        "ic": " li r1, 3\n nop\n nop\n nop\n"
                                              " ldg r2, [r1 + 40]\n halt\n",
                                        "sc": " recv r1, ring\n halt\n"}, (),
                                       "ICGM address 43"),
}


@pytest.mark.parametrize("sources,args,message", FAULTS.values(), ids=FAULTS.keys())
def test_faults_end_alike(run_pair, sources, args, message):
    code, err = run_pair(sources, *args)
    assert code == 2 and "run-time fault" in err and message in err


RING_DEADLOCK = {s: (Path(__file__).parent / "programs" / "ring_deadlock" / f"{s}.s").read_text()
                 for s in ("os", "ic", "sc")}
"""The ring-deadlock programs of test_emulator_cli.py."""

DEADLOCKS = {
    # the shared-FIFO ring deadlock of tests/test_emulator_cli.py (no buffer pool)
    "ring-no-buffer-pool": (RING_DEADLOCK, ("--set", "ring.buffer_pool=false",
                                            "--set", "ring.deadlock_cycles=100"), "deadlock in pe0"),
    "ring-two-pes-dynamic": (RING_DEADLOCK, ("--set", "ring.buffer_pool=false", "--pes", "2",
                                             "--set", "distribution=dynamic",
                                             "--set", "ring.deadlock_cycles=300"), "deadlock in pe"),
    "ring-shallow-fifos": (RING_DEADLOCK, ("--set", "ring.buffer_pool=false",
                                           "--set", "ring.fifo_depth=1",
                                           "--set", "ring.link_latency=2",
                                           "--set", "ring.deadlock_cycles=40"), "deadlock in pe0"),
    # a message announcing more words than OS sends holds the ring; IC waits on its receive
    # FIFO for a word that never comes
    "recv-never-answered": ({"ic": "recv r1, ring\n halt\n",
                             "os": f" li r1, {make_header(2, 2)}\n send ring, r1\n halt\n"},
                            ("--set", "ring.deadlock_cycles=64"), "deadlock"),
    # COL left in the middle of a pixel message
    "col-half-a-message": ({"sc": f" li r1, {COL_PIXEL}\n send col, r1\n send col, r0\n halt\n"},
                           (), "deadlock"),
    # a ring message cut short by its sender's halt (machine.unsent_messages): its header has
    # passed the CMU, or (a slow, one-word link) is still in the send FIFO behind a whole one
    "ring-half-a-message": ({"os": f" li r1, {make_header(3, 1)}\n send ring, r1\n"
                                   " send ring, r0\n halt\n"}, (),
                            "halted at pc 3, with 2 words of its message on `ring` never sent"),
    "ring-header-still-in-send-fifo": ({"os": f" li r1, {make_header(1, 2)}\n send ring, r1\n"
                                              " send ring, r0\n li r1, "
                                              f"{make_header(2, 1)}\n send ring, r1\n"
                                              " send ring, r0\n halt\n"},
                                       ("--set", "ring.link_buffer_words=1",
                                        "--set", "ring.link_latency=8"),
                                       "still in FIFO pe0.send.os"),
    # ... or by a sender that waits forever (formerly `finished`, exit 0)
    "ring-half-a-message-waiting": ({"ic": f" li r1, {make_header(2, 0)}\n send ring, r1\n"
                                           " send ring, r0\n recv r2, ring\n halt\n",
                                     "os": " recv r1, ring\n recv r1, ring\n recv r1, ring\n"
                                           " halt\n"}, (),
                                    "with 1 word of its message on `ring` never sent"),
}


@pytest.mark.parametrize("sources,args,message", DEADLOCKS.values(), ids=DEADLOCKS.keys())
def test_deadlocks_end_alike(run_pair, sources, args, message):
    code, err = run_pair(sources, *args)
    assert code == 3 and message in err


def test_deadlock_is_not_reached_with_the_buffer_pool(run_pair):
    code, _ = run_pair(RING_DEADLOCK, "--set", "ring.buffer_pool=true")
    assert code == 0


@pytest.mark.parametrize("limit", [1, 2, 37, 1000])
def test_cycle_limit_ends_alike(run_pair, limit):
    code, err = run_pair({"os": "loop: addi r1, r1, 1\n j loop\n",
                          "ic": " li r2, 3\nwait: addi r2, r2, -1\n bnez r2, wait\n halt\n"},
                         "--max-cycles", str(limit))
    assert code == 4 and f"cycle limit reached: {limit}" in err


# ---------------------------------------------------------------------------------------------
# 3. Random programs, images and configurations

REGS = st.sampled_from([0, 1, 2, 3, 4, 5, 6, 7, 63])
"""A few registers, so operations depend on each other (interlocks, port conflicts)."""
HEADERS = [make_header(n, d, c) for n in (0, 1, 2, 4) for d in range(4) for c in (0, 1)]
SMALL_INTS = st.integers(-4, 40)
INTS = st.one_of(SMALL_INTS, SMALL_INTS, st.sampled_from(HEADERS),
                 st.sampled_from([-(2 ** 31), 2 ** 31 - 1, -1, 1 << 16]),
                 st.integers(-(2 ** 31), 2 ** 31 - 1))
FLOATS = st.one_of(st.sampled_from([0.0, -0.0, 0.5, 1.0, -2.0, 3.25, 1e-30, 1e30, float("inf"),
                                    float("-inf"), float("nan")]),
                   st.floats(-1e6, 1e6, allow_nan=False, width=32))
OFFSETS = st.one_of(st.integers(0, 40), st.integers(-3, 3), st.integers(-(2 ** 20), 2 ** 20))


@st.composite
def programs(draw, proc: str) -> Program:
    """A small program every bundle of which passes the resource checker; branch targets are
    bundles of the program (the assembler refuses others; `jr` may still leave it)."""
    n = draw(st.integers(3, 16))
    halts = draw(st.integers(0, 4)) > 0  # usually an end, sometimes running off the program
    bundles = random_bundles(draw, proc, n, regs=REGS, imms=INTS, floats=FLOATS, offsets=OFFSETS,
                             last_label=n if halts else n - 1, min_ops=1, empty=Op("nop"))
    if halts:
        bundles.append((Op("halt"),))
    data = draw(st.lists(st.one_of(SMALL_INTS.map(lambda v: ("i", v)),
                                   FLOATS.map(lambda v: ("f", v))), max_size=6))
    return Program(proc, bundles, data, {})


def _words(draw, max_size: int) -> list[Segment]:
    ints = draw(st.lists(INTS, max_size=max_size))
    floats = draw(st.lists(FLOATS, max_size=max_size))
    at = draw(st.integers(0, 2))
    chunks = [("i", np.array(ints, np.int64)), ("f", np.array(floats, np.float64))]
    return [Segment(at, [c for c in chunks if len(c[1])])] if ints or floats else []


@st.composite
def images(draw) -> MemoryImage:
    image = MemoryImage()
    for key in ("os.local", "ic.local", "sc.local", "ic.resident", "sc.resident", "icgm", "scgm"):
        segs = _words(draw, 3 if key.endswith("resident") else 12)  # 8 words fit any resident
        if segs:
            image.memories[key] = segs
    for name in ("icgm", "scgm"):  # loads beyond what the image writes fault
        if draw(st.booleans()):
            used = max((seg.at + len(seg) for seg in image.memories.get(name, [])), default=0)
            image.sizes[name] = max(used, draw(st.integers(0, 96)))
    host = []
    for _ in range(draw(st.integers(0, 4))):
        n = draw(st.integers(0, 3))
        host += [make_header(n, draw(st.integers(0, 3)), draw(st.integers(0, 1)))]
        host += draw(st.lists(SMALL_INTS, min_size=n, max_size=n))
    if host:
        image.host = [Segment(0, [("i", np.array(host, np.int64))])]
    if draw(st.booleans()):
        image.frame = (draw(st.integers(1, 3)), draw(st.integers(1, 3)))
    if draw(st.booleans()):
        spaces = draw(st.sampled_from(["ic.global", "ic.resident", "sc.global", "os.local"]))
        start = draw(st.integers(0, 8))
        image.regions[spaces] = [
            Region(start, start + 4, draw(st.sampled_from(sorted(REGION_NAMES))), None),
            Region(start + 4, start + 10, "shape_data", draw(st.integers(0, 3)))]
    return image


LATENCY_OPS = {proc: sorted(m for m, o in opcodes_for(proc).items()
                            if o.kind not in ("nop",) and not (o.kind == "load" and proc != "os"))
               for proc in STAGES}


@st.composite
def config_sets(draw) -> list[str]:
    sets = [f"pes={draw(st.integers(1, 2))}",
            f"precision={draw(st.sampled_from(['fp32', 'fp64']))}",
            f"distribution={draw(st.sampled_from(['static', 'dynamic']))}",
            f"ring.deadlock_cycles={draw(st.integers(8, 200))}"]
    for proc in STAGES:
        for m in draw(st.lists(st.sampled_from(LATENCY_OPS[proc]), max_size=3, unique=True)):
            sets.append(f"{proc}.latency.{m}={draw(st.integers(1, 24))}")
        if draw(st.booleans()):
            sets.append(f"{proc}.taken_branch_penalty={draw(st.integers(0, 3))}")
    for mem in ("ic_memory", "sc_memory"):
        t_r = draw(st.integers(1, 3))
        t_c = t_r + draw(st.integers(0, 3))
        t_g = t_c + draw(st.integers(0, 16))
        block = draw(st.sampled_from([16, 32, 64]))
        sets += [f"{mem}.t_r={t_r}", f"{mem}.t_c={t_c}", f"{mem}.t_g={t_g}",
                 f"{mem}.block_bytes={block}",
                 f"{mem}.cache_bytes={block * draw(st.sampled_from([1, 2, 4, 16]))}",
                 f"{mem}.resident_bytes={draw(st.sampled_from([64, 256, 8192]))}"]
    sets += [f"ring.fifo_depth={draw(st.integers(1, 12))}",
             f"ring.link_latency={draw(st.integers(1, 4))}",
             f"ring.link_buffer_words={draw(st.integers(1, 6))}",
             f"ring.buffer_pool={draw(st.sampled_from(['true', 'false']))}"]
    return sets


def _state(engine) -> dict:
    """Everything a reader of the engine interface can see after a run."""
    out = {"status": engine.status, "cycle": engine.cycle, "exit_code": engine.exit_code,
           "error": engine.result().error.format() if engine.result().error else None,
           "statistics": run_stats.dumps(run_stats.without_engine(engine.statistics())),
           "summary": engine.summary(),
           "frame": engine.frame.tobytes(), "ids": engine.ids.tobytes()}
    for proc in engine.processors():
        out[f"{proc}.registers"] = engine.registers(proc)
        out[f"{proc}.pc"] = engine.pc(proc)
        for space in ("local", "resident", "global"):
            try:
                out[f"{proc}.{space}"] = np.asarray(engine.memory(proc, space)).tobytes()
            except KeyError:
                pass
    return out


def _build_and_run(name: str, sets, progs, image, max_cycles: int):
    try:
        engine = make_engine(name, load_config(None, sets), progs, image)
    except NetsushisenError as err:  # bad input: both engines must refuse it alike
        return {"refused": err.format()}
    engine.run(max_cycles)
    return _state(engine)


def _check_random_case(data) -> None:
    sets = data.draw(config_sets(), label="config")
    try:
        load_config(None, sets).validate()
    except ConfigError:
        return
    present = data.draw(st.lists(st.sampled_from(STAGES), min_size=1, max_size=3, unique=True),
                        label="stages")
    progs = {s: data.draw(programs(s), label=s) if s in present else None for s in STAGES}
    image = data.draw(images(), label="image")
    max_cycles = data.draw(st.integers(1, 600), label="max_cycles")
    for s, prog in progs.items():
        if prog is not None:
            note(f"--- {s}\n{disassemble(prog)}")
    ref = _build_and_run("reference", sets, progs, image, max_cycles)
    comp = _build_and_run("compiled", sets, progs, image, max_cycles)
    assert ref.keys() == comp.keys()
    for key in ref:
        assert ref[key] == comp[key], f"{key} differs (reference, then compiled)"


@settings(max_examples=50, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
@given(data=st.data())
def test_random_programs_run_alike(data):
    _check_random_case(data)


@pytest.mark.slow
@settings(max_examples=400, deadline=None,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
@given(data=st.data())
def test_random_programs_run_alike_many(data):
    _check_random_case(data)
