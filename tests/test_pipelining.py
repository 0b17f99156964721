"""Software pipelining and linear-assembly regions (docs/scheduling.md): the dot-product example
against its serial form on every engine (results, at most 0.6× the cycles, a steady state within
1.3× of the bound printed), trip counts 0..3 and random, the reasons a loop is not pipelined, the
region errors, the source map in object files and listings, and the `asm` options."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from netsushisen.asm.assembler import Assembler, AssemblyError
from netsushisen.asm.listing import listing, source_bundles
from netsushisen.asm.objects import Program
from netsushisen.emulator.harness import ProcessorView, run_machine
from netsushisen.isa.config import MachineConfig, load_config
from netsushisen.isa.images import image_from_json

EXAMPLE = Path(__file__).resolve().parents[1] / "kernels" / "examples" / "dot_ic.s"
PAIRS = [float((i * 7) % 11) * 0.5 - 1.25 for i in range(2 * 160)]


def build(n: int, config: MachineConfig | None = None, schedule: bool = True, path=EXAMPLE):
    asm = Assembler("ic", {"N": n}, config=config, schedule=schedule)
    return asm.assemble_file(path), asm.pipeline_reports


def run(program: Program, engine: str, config: MachineConfig | None = None):
    e = run_machine(engine, config or MachineConfig(), {"ic": program},
                    image_from_json({"ic.resident": PAIRS}), max_cycles=200_000)
    assert e.result().status == "halted"
    v = ProcessorView(e, "pe0.ic")
    return v.cycles, v.raw(10), v.raw(1)


def test_dot_product_pipelined_beats_its_serial_form(engine_name):
    pipelined, reports = build(64)
    serial, none = build(64, schedule=False)
    assert none == [] and len(reports) == 1
    r = reports[0]
    assert not r.reason and r.stages >= 2 and r.ii == max(r.res_mii, r.rec_mii, r.port_mii)
    fast, slow = run(pipelined, engine_name), run(serial, engine_name)
    assert fast[1:] == slow[1:]  # the same sum (bit for bit) and index
    assert fast[0] <= 0.6 * slow[0]
    # steady state: the cycles one more iteration costs
    per_iteration = (fast[0] - run(build(32)[0], engine_name)[0]) / 32
    assert per_iteration <= 1.3 * max(r.res_mii, r.rec_mii)


@pytest.mark.parametrize("trips", [0, 1, 2, 3])
def test_trip_counts_0_to_3(engine_name, trips):
    config = load_config(None, ["ic.latency.fmul=7"])  # three stages: the guard's fallback runs
    pipelined, reports = build(trips, config)
    assert reports[0].stages == 3
    assert run(pipelined, engine_name, config)[1:] == \
        run(build(trips, config, schedule=False)[0], engine_name, config)[1:]


@settings(max_examples=5, deadline=None, suppress_health_check=list(HealthCheck))
@given(n=st.integers(0, 150), fmul=st.integers(1, 9), fadd=st.integers(1, 5),
       penalty=st.integers(0, 3), t_r=st.integers(1, 3))
def test_random_trip_counts_and_latencies(engine_name, n, fmul, fadd, penalty, t_r):
    config = load_config(None, [f"ic.latency.fmul={fmul}", f"ic.latency.fadd={fadd}",
                                f"ic.taken_branch_penalty={penalty}", f"ic_memory.t_r={t_r}"])
    pipelined, reports = build(n, config)
    assert not reports[0].reason or "gains nothing" in reports[0].reason  # short latencies
    assert run(pipelined, engine_name, config)[1:] == \
        run(build(n, config, schedule=False)[0], engine_name, config)[1:]


def loop_source(body: str, temps: str = ".temps r40-r47") -> str:
    return f""".proc ic
.sched
{temps}
        li r1, 0
        li r9, 8
        lf r10, 0.0
.pipeline
loop:
{body}
done:   halt
.endsched
"""


@pytest.mark.parametrize("body, reason", [
    ("ldr r5, [r1]\nfadd r10, r10, r5\naddi r1, r1, 1\nbnez r5, loop",
     "its branch tests r5, which is not an induction"),
    ("ldr r5, [r1]\naddi r1, r1, 1\nblt r1, r9, elsewhere\nelsewhere: j loop",
     "not a single-block loop"),
    ("ldr r5, [r1]\naddi r1, r1, 1\nbnez r9, loop", "tests no induction register"),
    ("ldr r5, [r1]\naddi r1, r1, 1\naddi r9, r9, -1\nblt r1, r9, loop", "two induction registers"),
    ("ldr r5, [r1]\naddi r1, r1, 1\nj loop", "not a conditional branch"),
])
def test_a_loop_that_cannot_be_pipelined_says_why_and_is_list_scheduled(body, reason):
    asm = Assembler("ic")
    asm.assemble_text(loop_source(body))
    assert len(asm.pipeline_reports) == 1 and reason in asm.pipeline_reports[0].reason
    assert "not pipelined: " + asm.pipeline_reports[0].reason in asm.pipeline_reports[0].format()


def test_a_loop_pipelining_cannot_speed_up_is_left_list_scheduled():
    body = "ldr r5, [r1]\nfadd r10, r10, r5\naddi r1, r1, 1\nblt r1, r9, loop"
    for penalty, reason in ((0, "pipelining gains nothing: II 3 against 3 cycles"), (1, "")):
        asm = Assembler("ic", config=load_config(None, [f"ic.taken_branch_penalty={penalty}",
                                                         "ic.latency.fadd=1"]))
        asm.assemble_text(loop_source(body))
        assert asm.pipeline_reports[0].reason.startswith(reason)  # 1: unrolled, it saves a penalty
        assert bool(asm.pipeline_reports[0].reason) == bool(reason)


def test_registers_trade_for_ii_and_too_few_is_a_reason():
    body = "ldr r2, [r1]\nfmul r4, r2, r2\nfadd r10, r10, r4\naddi r1, r1, 1\nblt r1, r9, loop"
    config = load_config(None, ["ic.latency.fmul=12"])  # r4 lives three IIs: copies needed

    def report(temps: str, cfg=config):
        asm = Assembler("ic", config=cfg)
        asm.assemble_text(loop_source(body, temps))
        return asm.pipeline_reports[0]

    many, one = report(".temps r40-r47"), report(".temps r40")
    assert not many.reason and many.ii == many.mii and many.unroll >= 3
    assert not one.reason and one.ii > many.ii and one.registers == (40,)
    none = report("", load_config(None, ["ic.latency.fmul=40"]))
    assert "registers for its copies and guard" in none.reason and ".temps grants 0" in none.reason


@pytest.mark.parametrize("text, message", [
    (".sched\n{ add r1, r2, r3 ; add r4, r5, r6 }\n.endsched\nhalt\n", "one operation per line"),
    (".pipeline\nloop: halt\n", ".pipeline outside a .sched region"),
    (".sched\nhalt\n", ".sched without a matching .endsched"),
    (".sched\n.sched\nhalt\n.endsched\n", ".sched inside a .sched region"),
    (".sched\n.temps 5\nhalt\n.endsched\n", ".temps takes registers"),
    (".sched\n.pipeline\nadd r1, r1, r1\nhalt\n.endsched\n", ".pipeline must be followed by the loop's label"),
    (".endsched\nhalt\n", ".endsched outside a .sched region"),
])
def test_region_errors_are_located(text, message):
    with pytest.raises(AssemblyError) as err:
        Assembler("ic").assemble_text(text, "r.s")
    assert message in err.value.format() and "r.s:" in err.value.format()


def test_labels_move_with_the_schedule_and_hand_bundles_stay():
    text = """.proc ic
        { li r1, 3 ; lf r2, 1.0 }
.sched
        lf r3, 2.0
        fmul r4, r2, r3
        addi r1, r1, -1
again:  fadd r5, r4, r4
        bnez r1, after
        li r6, 7
after:  halt
.endsched
"""
    p = Assembler("ic").assemble_text(text)
    assert p.bundles[0] == Assembler("ic").assemble_text(text.split(".sched")[0] + "halt\n").bundles[0]
    labels = {n: a for n, (s, a) in p.labels.items()}
    assert [op.mnemonic for op in p.bundles[labels["again"]]][0] == "fadd"
    assert p.bundles[labels["after"]][0].mnemonic == "halt"
    # every operation of the region is in exactly one bundle, with its own source line
    lines = {line for (f, line, via) in source_bundles(p)}
    assert lines == set(range(2, 11)) - {3}


def test_object_file_keeps_op_sources_and_loads_without_them(tmp_path):
    p, _ = build(4)
    path = tmp_path / "dot.o"
    p.save(path)
    back = Program.load(path)
    assert back.op_sources == p.op_sources and back.same_program(p)
    assert any(len({s.line for s in ops}) > 1 for ops in back.op_sources)
    obj = json.loads(path.read_text())
    del obj["op_sources"]
    old = Program.from_json(obj)
    assert old.op_sources == [] and old.same_program(p)
    assert "scheduled source lines" not in listing(old)


def test_listing_maps_every_loop_line_to_its_bundles():
    p, _ = build(16)
    text = listing(p)
    assert "; scheduled source lines -> bundles" in text
    rows = [r for r in text.splitlines() if r.startswith(";   ") and "dot_ic.s" in r]
    for op in ("ldr a, [i + 0]", "ldr b, [i + 1]", "fmul product, a, b", "fadd sum, sum, product",
               "addi i, i, 2", "blt i, end, loop"):
        row = next(r for r in rows if op in r)
        assert len(row.split("->")[1].split(",")) >= 3  # prologue or kernel copies, fallback


def test_asm_prints_the_pipelining_information_for_the_configuration_given(cli, tmp_path):
    fast = cli("asm", EXAMPLE, "--stats", "-D", "N=8")
    slow = cli("asm", EXAMPLE, "--stats", "-D", "N=8", "--set", "ic.latency.fmul=9")
    assert fast[0] == 0 and slow[0] == 0, fast[2] + slow[2]
    for _, out, _ in (fast, slow):
        assert "software pipelining information: loop 'loop'" in out
        assert "recurrence bound        : 2   (fadd r10: 2 cycles over 1 iteration)" in out
        assert "resource bound (units)  : 4" in out and "II achieved             : 4" in out
    code, out, _ = cli("asm", EXAMPLE, "--stats", "--json", "-D", "N=8")
    info = json.loads(out)["pipelines"]
    assert code == 0 and [(p["loop"], p["pipelined"], p["ii"], p["res_mii"]) for p in info] == \
        [("loop", True, 4, 4)]
    assert "stages                  : 2" in fast[1]
    assert "stages                  : 3" in slow[1]  # rescheduled for the longer fmul
    bad = tmp_path / "bad.s"
    bad.write_text(loop_source("ldr r5, [r1]\naddi r1, r1, 1\nbnez r5, loop"))
    code, out, _ = cli("asm", EXAMPLE, "--listing", "-", "-D", "N=8")
    lines = out.split("; scheduled source lines -> bundles")[1]
    for n in range(26, 38):  # every line of the region, alone in a bundle or not
        assert (f"dot_ic.s:{n} " in lines) == (n != 30), n
    assert "li end, PAIRS + 2 * N" in lines and "# N = 0" not in lines
    code, out, err = cli("asm", bad, "--stats")
    assert code == 0
    assert f"{bad}:8: warning: loop 'loop' not pipelined: its branch tests r5" in err
    code, _, err = cli("asm", bad, "--stats", "--set", "ic.latency.fmul=0")
    assert code == 1 and "ic.latency.fmul" in err and "Traceback" not in err


def test_run_schedules_a_source_for_the_run_configuration(cli, tmp_path):
    image = tmp_path / "pairs.json"
    image.write_text(json.dumps({"ic.resident": PAIRS}))
    bundles = {}
    for fmul in (3, 9):
        out = tmp_path / f"stats{fmul}.json"
        code, _, err = cli("run", "--ic", EXAMPLE, "--image", image, "-D", "N=16", "--engine",
                           "reference", "--set", f"ic.latency.fmul={fmul}", "--json", out)
        assert code == 0, err
        bundles[fmul] = json.loads(out.read_text())["programs"]["ic"]["bundles"]
    assert bundles[9] == len(build(16, load_config(None, ["ic.latency.fmul=9"]))[0].bundles)
    assert bundles[3] == len(build(16)[0].bundles) != bundles[9]


def test_hand_written_code_has_no_scheduled_lines_map():
    text = ".proc ic\n.rept 3\nfadd r1, r1, r1\n.endr\n{ li r2, 1 ; lf r3, 1.0 }\nhalt\n"
    assert "scheduled source lines" not in listing(Assembler("ic").assemble_text(text))
    scheduled = ".proc ic\n.sched\n.rept 3\nfadd r1, r1, r1\n.endr\nli r2, 1\nlf r3, 1.0\nhalt\n.endsched\n"
    assert "scheduled source lines" in listing(Assembler("ic").assemble_text(scheduled))


def test_annotate_names_the_source_lines_of_a_scheduled_bundle(cli, tmp_path):
    image = tmp_path / "pairs.json"
    image.write_text(json.dumps({"ic.resident": PAIRS}))
    stats = tmp_path / "stats.json"
    code, _, err = cli("run", "--ic", EXAMPLE, "--image", image, "-D", "N=16", "--engine",
                       "reference", "--json", stats)
    assert code == 0, err
    code, out, err = cli("report", "annotate", stats, "--proc", "ic", "--order", "program",
                         "--format", "json")
    rows = [r for s in json.loads(out)["sections"] if s["key"] == "bundles" for r in s["rows"]]
    program = build(16)[0]
    assert len(rows) == len(program.bundles)
    for row in rows:
        lines = dict.fromkeys(s.line for s in program.op_sources[row["pc"]])
        assert row["source lines"] == "dot_ic.s:" + ", ".join(map(str, lines))
    assert any("," in (row["source lines"] or "") for row in rows)  # a bundle of several lines


LOOPS = {  # more loop shapes: counting down to zero, local stores and loads, unpipelined fdiv
    "countdown": ("li r1, {n}\nlf r10, 0.0\nbeqz r1, done", "ldr r2, [r1]\nfmul r3, r2, r2\n"
                  "fadd r10, r10, r3\naddi r1, r1, -1\nbnez r1, loop"),
    "stores": ("li r1, 0\nli r9, {n}\nlf r10, 1.0\nbge r1, r9, done",
               "ldr r2, [r1]\nfmul r3, r2, r10\nst r3, [r1 + 100]\nld r4, [r1 + 99]\n"
               "fadd r10, r4, r2\naddi r1, r1, 1\nblt r1, r9, loop"),
    "fdiv": ("li r1, 0\nli r9, {n}\nlf r10, 0.0\nbge r1, r9, done",
             "ldr r2, [r1]\nldr r3, [r1 + 1]\nfdiv r4, r2, r3\nfadd r10, r10, r4\n"
             "addi r1, r1, 1\nblt r1, r9, loop"),
}


@pytest.mark.parametrize("shape", sorted(LOOPS))
@pytest.mark.parametrize("trips", [1, 2, 11])
def test_loop_shapes_at_small_trip_counts(engine_name, shape, trips):
    head, body = LOOPS[shape]
    text = f".proc ic\n.sched\n.temps r40-r50\n{head.format(n=trips)}\n.pipeline\nloop:\n{body}\ndone: halt\n.endsched\n"
    config = load_config(None, ["ic.latency.fmul=6", "ic.latency.fadd=3"])
    results = []
    for schedule in (True, False):
        asm = Assembler("ic", config=config, schedule=schedule)
        p = asm.assemble_text(text)
        if schedule:
            assert not asm.pipeline_reports[0].reason and asm.pipeline_reports[0].stages >= 2
        e = run_machine(engine_name, config, {"ic": p}, image_from_json({"ic.resident": PAIRS}),
                        max_cycles=100_000)
        assert e.result().status == "halted"
        regs = [w for r, w in enumerate(e.registers("pe0.ic")) if not 40 <= r <= 50]  # not .temps
        results.append((regs, list(e.memory("pe0.ic", "local")[:120])))
    assert results[0] == results[1]


def test_calls_and_returns_inside_a_region(engine_name):
    text = """.proc ic
.sched
        li r2, 5
        lf r3, 1.5
        fmul r4, r3, r3
        call twice
        fadd r5, r4, r3
        addi r2, r2, 1
        call twice
        halt
twice:  add r2, r2, r2
        fadd r4, r4, r4
        ret
.endsched
"""
    results = []
    for schedule in (True, False):
        p = Assembler("ic", schedule=schedule).assemble_text(text)
        e = run_machine(engine_name, MachineConfig(), {"ic": p}, max_cycles=10_000)
        assert e.result().status == "halted"
        results.append([e.registers("pe0.ic")[r] for r in (2, 3, 4, 5)])
        if schedule:
            assert len(p.bundles) < 11
    assert results[0] == results[1]


# ---------------------------------------------------------------------------------------------
# The information block above its loop, TI's way (issue 42, item 3)


def test_the_information_block_sits_above_the_loop_with_its_parts_marked(cli, tmp_path):
    from netsushisen.kernels import KERNELS

    dot = KERNELS / "examples" / "dot_ic.s"
    code, out, err = cli("asm", dot, "--listing", "-", "-D", "N=8")
    assert code == 0, err
    lines = out.splitlines()
    head = next(i for i, line in enumerate(lines) if "software pipelining information" in line)
    label = lines.index("loop:")
    first_bundle = next(i for i, line in enumerate(lines) if line.strip().startswith("3 "))
    assert head < label < first_bundle  # above the loop's first bundle (the guard's)
    marks = [line for line in lines if line.startswith(";** ")]
    assert marks == [";** guard", ";** PROLOG", ";** KERNEL", ";** EPILOG", ";** fallback"]
    kernel = lines.index(";** KERNEL")
    assert lines[kernel + 1].split()[0] == "8"  # the branch back targets loop+5 = 8
    block = "\n".join(lines[head:label])
    assert ";*                             int       4      1  4/4" in block
    assert "registers live in kernel: 7 (r1, r2, r3, r4, r9, r10, r40)" in block
    assert "1 of 8 .temps (r40), 7 left" in block
    assert out.count("software pipelining information") == 1  # not repeated after the code
    code, out, err = cli("asm", dot, "--stats", "--json", "-D", "N=8")
    info = json.loads(out)["pipelines"][0]
    assert info["resources"] == {"int": {"busy": 4, "units": 1}, "fp": {"busy": 2, "units": 3}}
    assert info["temps_left"] == 7 and info["live_registers"][-1] == "r40"
    assert info["parts"]["kernel"] == 5 and info["tried"] == []


def test_the_iis_tried_say_why_each_failed(cli, tmp_path):
    """Without .temps, dot's two-stage schedules at II 4 and 5 have no register for their
    guard: each II tried is listed with its reason, and II 6 (one stage, no guard) is taken."""
    from netsushisen.kernels import KERNELS

    src = tmp_path / "dot0.s"
    src.write_text((KERNELS / "examples" / "dot_ic.s").read_text()
                   .replace(".temps r40-r47", ""))
    code, out, err = cli("asm", src, "--stats", "--json")
    assert code == 0, err
    info = json.loads(out)["pipelines"][0]
    assert info["tried"] == ["4: needs 1 .temps for its copies and guard, 0 granted",
                             "5: needs 1 .temps for its copies and guard, 0 granted"]
    assert info["ii"] == 6 and info["stages"] == 1 and info["temps_left"] == 0
    code, out, err = cli("asm", src, "--stats")
    assert ";*   II 4: needs 1 .temps for its copies and guard, 0 granted" in out
    assert ";*   resources per iteration : unit   busy  units  slots used at II 6" in out
