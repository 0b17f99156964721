"""The compiled engine's tables are generated from the facts (issue 45, item 2): its stall-cause
ids are numbered from the one stall table (isa/stalls.py), and its arrays are allocated from
their declared shapes and dtypes (emulator/compiled/state.py ARRAYS), so a cause added to the
table alone reaches both engines' statistics and every report, and an array that strays from
its declaration is caught. No numba: flatten and write_back are the compiled engine's whole
mapping between cause names and ids, and they run in plain Python."""

from __future__ import annotations

import json
import subprocess
import sys
import textwrap

from netsushisen.emulator.compiled import state as St
from netsushisen.isa import stalls as S


def test_stall_ids_are_numbered_from_the_one_table():
    assert St.CAUSES == ("", "halted") + S.concrete_causes()
    named = {St.CAUSE_NONE: "", St.CAUSE_HALTED: "halted", St.CAUSE_BRANCH: S.BRANCH,
             St.CAUSE_LOCAL: S.LOCAL, St.CAUSE_RESIDENT: S.RESIDENT,
             St.CAUSE_CACHE_HIT: S.CACHE_HIT, St.CAUSE_CACHE_MISS: S.CACHE_MISS,
             St.CAUSE_WRITE_PORT: S.WRITE_PORT, St.CAUSE_FIFO_ANY: S.FIFO_ANY}
    assert {i: St.CAUSES[i] for i in named} == named
    # the loop adds a port id or a mnemonic id + 1 to a family's base
    for port, i in zip(St.PORTS, range(len(St.PORTS))):
        assert St.CAUSES[St.CAUSE_FIFO_EMPTY + i] == S.stall(S.FIFO_EMPTY, port)
        assert St.CAUSES[St.CAUSE_FIFO_FULL + i] == S.stall(S.FIFO_FULL, port)
    for base, family in ((St.CAUSE_OPERAND, S.OPERAND), (St.CAUSE_WAW, S.WAW),
                         (St.CAUSE_UNIT, S.UNIT_BUSY)):
        assert St.CAUSES[base] == S.stall(family, "")
        for m, i in St.MN_ID.items():
            assert St.CAUSES[base + i + 1] == S.stall(family, m)
    assert [St.CAUSE_ID[c] for c in St.CAUSES] == list(range(len(St.CAUSES)))
    assert all(St.CAUSE_FLAGS[St.CAUSE_FIFO_EMPTY + i] == 2 for i in range(3))
    assert St.CAUSE_FLAGS[St.CAUSE_BRANCH] == 0 and St.CAUSE_FLAGS[St.CAUSE_FIFO_FULL] == 1


_ADD_A_CAUSE = textwrap.dedent('''
    import contextlib, io, json, sys
    from netsushisen.isa import stalls as S

    # the one edit: a cause in the stall table, before any engine is built
    S.CAUSES = S.CAUSES + (S.Cause("probe", "resource", "T5", False, "a planted cause",
                                   "nothing to do", "#123456"),)

    from netsushisen.asm.assembler import assemble_text
    from netsushisen.cli import main
    from netsushisen.emulator import stats
    from netsushisen.emulator.compiled import state as St
    from netsushisen.emulator.engine import ReferenceEngine
    from netsushisen.isa.config import load_config
    from netsushisen.isa.images import image_from_json

    src = {"ic": "li r1, 3\\nloop:\\nldg r2, [r1 + 0]\\naddi r1, r1, 1\\nslti r4, r1, 40\\n"
                 "bnez r4, loop\\nsend ring, r0\\nhalt\\n", "os": "recv r1, ring\\nhalt\\n"}
    def engine():
        programs = {p: assemble_text(s, proc=p) for p, s in src.items()}
        return ReferenceEngine(load_config(None, []), programs,
                               image_from_json({"icgm": [float(i) for i in range(128)]}))
    ran = engine()
    ran.run()
    ic = next(c for c in ran.machine.cores if c.name.endswith(".ic"))
    # the reference engine charges the new cause: some of a stall's cycles move to it
    pc, causes = max(ic.stalls_by_pc.items(), key=lambda kv: sum(kv[1].values()))
    old = max(causes, key=causes.get)
    moved = causes[old] // 2
    causes[old] -= moved
    causes["probe"] = moved
    ic.stalls[old] -= moved
    ic.stalls["probe"] = moved
    # the compiled engine's state: its ids, its counters, written back into a fresh machine
    st = St.flatten(ran.machine)
    p = ran.machine.cores.index(ic)
    fresh = engine()
    St.write_back(st, fresh.machine)
    out = {"id": St.CAUSE_ID["probe"], "columns": st.arrays["stpc"].shape[2],
           "counted": int(st.arrays["stpc"][p, pc, St.CAUSE_ID["probe"]]),
           "reference": stats.collect(ran.machine)["processors"][ic.name]["stalls"],
           "compiled": stats.collect(fresh.machine)["processors"][ic.name]["stalls"]}
    path = sys.argv[1]
    stats.write(fresh.machine, path)
    for report in (["stalls", path, "--explain"], ["annotate", path, "--proc", ic.name],
                   ["flat", path], ["stalls", "--explain"], ["diff", path, path]):
        buf = io.StringIO()
        with contextlib.redirect_stdout(buf):
            code = main(["report", *report])
        out[" ".join(report[:1] + report[2:])] = (code, buf.getvalue())
    print(json.dumps(out))
''')


def test_a_cause_added_to_the_table_alone_reaches_both_engines_and_every_report(tmp_path):
    """The planted cause (a fixture edit of isa/stalls.py's table, in a fresh interpreter)
    gets an id and a column in the compiled state, survives flatten and write_back with its
    cycles, and is in the statistics of both engines and in each report that lists causes."""
    proc = subprocess.run([sys.executable, "-c", _ADD_A_CAUSE, str(tmp_path / "stats.json")],
                          capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr[-3000:]
    out = json.loads(proc.stdout.splitlines()[-1])
    assert out["id"] == len(St.CAUSES) and out["columns"] == len(St.CAUSES) + 1
    assert out["counted"] > 0
    assert out["compiled"] == out["reference"] and out["compiled"]["probe"] == out["counted"]
    reports = {k: v for k, v in out.items() if isinstance(v, list)}
    assert len(reports) == 5
    for report, (code, text) in reports.items():
        assert code == 0, report
        assert "probe" in text, (report, text[:500])
    assert "a planted cause" in out["stalls --explain"][1]


def test_every_array_has_its_declared_shape_and_dtype():
    """flatten allocates from ARRAYS; check_shapes holds the result to it, and catches an
    array of another shape or dtype."""
    from netsushisen.asm.assembler import assemble_text
    from netsushisen.emulator.engine import ReferenceEngine
    from netsushisen.isa.config import load_config
    from netsushisen.isa.images import image_from_json

    programs = {"ic": assemble_text("li r1, 2\nhalt\n", proc="ic"),
                "os": assemble_text("halt\n", proc="os")}
    st = St.flatten(ReferenceEngine(load_config(None, []), programs,
                                    image_from_json({"icgm": [1.0] * 8})).machine)
    assert St.check_shapes(st) == []
    assert set(St.DIMS) >= {d for a in St.ARRAYS.values() for d in a.shape if isinstance(d, str)}
    assert st.arrays["stpc"].shape[2] == len(St.CAUSES) and (st.arrays["prod"] == -1).all()
    st.arrays["bpc"] = st.arrays["bpc"][:, :-1]
    st.arrays["regs"] = st.arrays["regs"].astype("int32")
    assert [p.split(":")[0] for p in St.check_shapes(st)] == ["regs", "bpc"]


def test_the_loops_parameters_are_the_arrays_table_in_order():
    """run_loop's and run_cycles' positional parameters, and run_loop's call of run_cycles,
    are ARRAYS' names in ARG_ORDER (typed by hand in loop.py, so held to the table here: an
    array added to ARRAYS and not to the loop, or out of order, fails)."""
    import ast
    from pathlib import Path

    tree = ast.parse((Path(St.__file__).parent / "loop.py").read_text())
    funcs = {f.name: f for f in tree.body if isinstance(f, ast.FunctionDef)}
    for name in ("run_loop", "run_cycles"):
        assert tuple(a.arg for a in funcs[name].args.args) == St.ARG_ORDER, name
    calls = [n for n in ast.walk(funcs["run_loop"]) if isinstance(n, ast.Call)
             and getattr(n.func, "id", None) == "run_cycles"]
    assert [tuple(a.id for a in c.args) for c in calls] == [St.ARG_ORDER]
