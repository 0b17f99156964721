"""`render` / `run --timeline`: Kanata logs (Konata) and trace-event JSON (Perfetto).

The Kanata files are read back by a strict parser of the documented grammar (Konata's
docs/kanata-log-format.md, version 0004): every line a known command with its fields, ids
declared by `I` before use and retired by exactly one `R`, stages started and ended in order on
their lane, cycle deltas non-negative. The JSON is loaded with `json.load` and every event's
fields checked against the Trace Event Format. Both are held to what the machine did: the
statistics of the run (bundles, stall cycles by cause, cache misses, FIFO words left) and the
reference engine's text trace of the same window, cycle by cycle. The window's events come
from the reference engine after the engine under test (`engine_name`) has run to the window.
"""

from __future__ import annotations

import functools
import json
import re
from collections import Counter
from dataclasses import dataclass, field
from io import StringIO
from pathlib import Path

import pytest

from netsushisen.cli import main
from netsushisen.emulator.stats import without_engine
from netsushisen.emulator.trace import HOLD_CAUSES, Tracer
from netsushisen.isa.config import load_config
from netsushisen import pipeline

TETRA = ["render", "tetra", "--res", "4", "--quiet"]
WINDOW = (6_000, 7_500)


# ---------------------------------------------------------------------------------------------
# A strict Kanata 0004 reader


class KanataError(AssertionError):
    pass


@dataclass
class Row:
    id: int
    sim_id: int
    thread: int
    start: int
    label: str = ""
    detail: str = ""
    lanes: dict[int, list[list]] = field(default_factory=dict)  # lane -> [[name, start, end]]
    producers: list[int] = field(default_factory=list)  # W: the rows it woke up from
    retired: int | None = None
    retire_id: int | None = None
    flushed: bool = False


def _int(text: str, line: int, what: str) -> int:
    if not re.fullmatch(r"-?\d+", text):
        raise KanataError(f"line {line}: {what} {text!r} is not an integer")
    return int(text)


def read_kanata(text: str) -> list[Row]:
    """The rows of a Kanata 0004 log; KanataError on anything the format does not allow."""
    lines = text.split("\n")
    if lines[-1] != "":
        raise KanataError("the file does not end with a newline")
    lines = lines[:-1]
    if not lines or lines[0] != "Kanata\t0004":
        raise KanataError(f"line 1: expected the header 'Kanata<TAB>0004', got {lines[:1]}")
    rows: dict[int, Row] = {}
    live: set[int] = set()
    cycle = None
    next_id = 0
    for n, line in enumerate(lines[1:], start=2):
        f = line.split("\t")
        cmd = f[0]
        if cmd == "C=":
            if len(f) != 2 or cycle is not None:
                raise KanataError(f"line {n}: C= takes one field and comes once, before the rest")
            cycle = _int(f[1], n, "cycle")
            if cycle < 0:
                raise KanataError(f"line {n}: negative cycle")
            continue
        if cycle is None:
            raise KanataError(f"line {n}: {cmd} before C=")
        if cmd == "C":
            if len(f) != 2:
                raise KanataError(f"line {n}: C takes one field")
            delta = _int(f[1], n, "delta")
            if delta < 0:
                raise KanataError(f"line {n}: negative cycle delta {delta}")
            cycle += delta
            continue
        if cmd not in ("I", "L", "S", "E", "R", "W"):
            raise KanataError(f"line {n}: unknown command {cmd!r}")
        if len(f) != 4:
            raise KanataError(f"line {n}: {cmd} takes 3 fields, got {len(f) - 1}")
        rid = _int(f[1], n, "id")
        if cmd == "I":
            if rid in rows:
                raise KanataError(f"line {n}: id {rid} declared twice")
            if rid != next_id:
                raise KanataError(f"line {n}: ids are not sequential ({rid}, expected {next_id})")
            next_id += 1
            rows[rid] = Row(rid, _int(f[2], n, "sim id"), _int(f[3], n, "thread"), cycle)
            live.add(rid)
            continue
        if rid not in live:
            raise KanataError(f"line {n}: {cmd} for id {rid}, which is "
                              f"{'retired' if rid in rows else 'not declared'}")
        row = rows[rid]
        if cmd == "L":
            kind = _int(f[2], n, "label type")
            if kind == 0:
                row.label += f[3]
            elif kind == 1:
                row.detail += f[3]
            elif kind == 2:
                if not any(row.lanes.values()):
                    raise KanataError(f"line {n}: a type-2 label before any stage")
            else:
                raise KanataError(f"line {n}: label type {kind}")
        elif cmd == "S":
            lane = row.lanes.setdefault(_int(f[2], n, "lane"), [])
            if lane and lane[-1][2] is None:
                raise KanataError(f"line {n}: stage {f[3]} starts while {lane[-1][0]} is open")
            lane.append([f[3], cycle, None])
        elif cmd == "E":
            lane = row.lanes.get(_int(f[2], n, "lane"))
            if not lane or lane[-1][2] is not None or lane[-1][0] != f[3]:
                raise KanataError(f"line {n}: E {f[3]} without that stage open on its lane")
            lane[-1][2] = cycle
        elif cmd == "R":
            kind = _int(f[3], n, "retire type")
            if kind not in (0, 1):
                raise KanataError(f"line {n}: retire type {kind}")
            for lane in row.lanes.values():
                if lane and lane[-1][2] is None:
                    raise KanataError(f"line {n}: id {rid} retired with {lane[-1][0]} open")
            row.retired, row.retire_id, row.flushed = cycle, _int(f[2], n, "rid"), kind == 1
            live.discard(rid)
        else:  # W: consumer, producer, type (Konata v0.39 needs the producer not retired)
            producer = _int(f[2], n, "producer")
            if producer not in live or producer >= rid or _int(f[3], n, "type") != 0:
                raise KanataError(f"line {n}: W from {producer}, not a live earlier row, or "
                                  "not a wake-up")
            row.producers.append(producer)
    if live:
        raise KanataError(f"ids never retired: {sorted(live)[:5]}")
    out = list(rows.values())
    kept = [r.retire_id for r in out if not r.flushed]
    if sorted(kept) != list(range(len(kept))):
        raise KanataError("retire ids of the retired rows are not 0..n-1")
    return out


def issue_cycle(row: Row) -> int:
    (stage,) = row.lanes[0]
    assert stage[0] == "Is" and stage[2] == stage[1] + 1
    return stage[1]


# ---------------------------------------------------------------------------------------------
# Trace-event validation


def check_trace_events(doc: dict) -> list[dict]:
    """The events of a JSON Object Format trace, each checked against the Trace Event Format."""
    assert set(doc) >= {"traceEvents"} and isinstance(doc["traceEvents"], list)
    assert doc.get("displayTimeUnit", "ms") in ("ms", "ns")
    events = doc["traceEvents"]
    named_pids, named_threads = set(), set()
    for e in events:
        assert isinstance(e["name"], str) and e["name"]
        assert isinstance(e["pid"], int) and isinstance(e["tid"], int)
        assert isinstance(e["ts"], int) and e["ts"] >= 0
        assert isinstance(e.get("args", {}), dict)
        ph = e["ph"]
        if ph == "M":
            assert e["name"] in ("process_name", "thread_name", "process_sort_index",
                                 "thread_sort_index")
            if e["name"] == "process_name":
                named_pids.add(e["pid"])
            if e["name"] == "thread_name":
                named_threads.add((e["pid"], e["tid"]))
            assert e["args"]
        elif ph == "X":
            assert isinstance(e["dur"], int) and e["dur"] >= 1
            assert e["cat"] in ("bundle", "stall")
        elif ph == "C":
            assert e["args"] and all(isinstance(v, (int, float)) for v in e["args"].values())
        elif ph == "i":
            assert e["s"] in ("g", "p", "t")
        else:
            raise AssertionError(f"unexpected phase {ph!r}")
    for e in events:
        assert e["pid"] in named_pids
        if e["ph"] in ("X", "i"):
            assert (e["pid"], e["tid"]) in named_threads
    return events


# ---------------------------------------------------------------------------------------------
# helpers


def render(tmp_path: Path, engine: str, *extra: str, name: str = "t") -> tuple[int, dict]:
    stats = tmp_path / f"{name}.stats.json"
    code = main(TETRA + ["--engine", engine, "-o", str(tmp_path / f"{name}.png"),
                         "--json", str(stats), *extra])
    return code, (json.loads(stats.read_text()) if stats.exists() else {})


THREADS = {"pe0.os": 0, "pe0.ic": 1, "pe0.sc": 2}


@functools.cache
def reference_run(first: int, end: int) -> tuple[tuple[tuple[int, str, int, str], ...], dict]:
    """The reference engine's run of tetra 4x4 without a timeline: its text trace for cycles
    first..end, (cycle, processor, pc, what) per line, and its render statistics (the image's
    hash among them)."""
    setup = pipeline.prepare("tetra", load_config(None), 4)
    engine = setup.engine("reference")
    out = StringIO()
    engine.machine.tracer = Tracer(out, None, f"{first}:{end}")
    stats = pipeline.finish(setup, engine, engine.run()).stats
    lines = []
    for line in out.getvalue().splitlines():
        cycle, proc, pc, _label, what = line.split(None, 4)
        lines.append((int(cycle), proc, int(pc), what))
    return tuple(lines), stats


def text_trace(first: int, end: int) -> tuple[tuple[int, str, int, str], ...]:
    return reference_run(first, end)[0]


def tandem_refused(code: int, capsys) -> bool:
    err = capsys.readouterr().err
    assert code == 1 and "--engine tandem cannot hand over" in err and "Traceback" not in err
    return True


# ---------------------------------------------------------------------------------------------
# A whole render, each format. The window starts at cycle 0, so the reference engine steps the
# whole run whichever engine is chosen: these run the default engine; the window tests below,
# where the engine runs the machine to the window, run every engine.


def test_kanata_whole_render_has_every_bundle_once(tmp_path, capsys):
    path = tmp_path / "t.kanata"
    code, stats = render(tmp_path, "compiled", "--timeline", str(path))
    assert code == 0
    rows = read_kanata(path.read_text())
    issued = [r for r in rows if not r.flushed]
    procs = stats["processors"]
    per_thread = Counter(r.thread for r in issued)
    assert per_thread == Counter({THREADS[p]: procs[p]["bundles"] for p in THREADS})
    # per PC: each bundle's issue count equals the statistics' bundles_by_pc
    for p, t in THREADS.items():
        by_pc = Counter(str(r.sim_id) for r in issued if r.thread == t)
        assert by_pc == Counter(procs[p]["bundles_by_pc"])
    # stall stages: the cycles by cause equal the statistics' stalls by cause
    for p, t in THREADS.items():
        causes = Counter()
        for r in rows:
            if r.thread == t:
                for name, start, end in r.lanes.get(1, []):
                    causes[name] += end - start
        assert causes == Counter(procs[p]["stalls"])
    # each issued row: one issue stage; each op lane an X stage from issue, then a Wb or none
    for r in issued:
        c = issue_cycle(r)
        for lane, stages in r.lanes.items():
            if lane >= 2:
                assert stages[0][0].startswith("X.") and stages[0][1] == c
                assert [s[0] for s in stages[1:]] in ([], ["Wb"])
                if len(stages) == 2:
                    assert stages[1][1] == stages[0][2] and stages[1][2] == stages[1][1] + 1
    # rows still waiting when the run ended are the only flushed ones
    assert all(0 not in r.lanes for r in rows if r.flushed)
    err = capsys.readouterr().err
    assert f"timeline: wrote {path}: cycles 0 to {stats['run']['cycles']:,}" in err


def test_json_whole_render_tracks_bundles_stalls_misses_and_fifos(tmp_path):
    path = tmp_path / "t.json"
    code, stats = render(tmp_path, "compiled", "--timeline", str(path))
    assert code == 0
    with open(path, encoding="utf-8") as f:
        events = check_trace_events(json.load(f))
    procs = stats["processors"]
    meta = {(e["pid"], e["tid"]): e["args"]["name"] for e in events
            if e["ph"] == "M" and e["name"] == "thread_name"}
    assert meta == {(0, 0): "pe0.os (OS)", (0, 1): "pe0.ic (IC)", (0, 2): "pe0.sc (SC)"}
    for p, tid in THREADS.items():
        mine = [e for e in events if e["ph"] == "X" and e["tid"] == tid]
        bundles = [e for e in mine if e["cat"] == "bundle"]
        assert len(bundles) == procs[p]["bundles"]
        assert all(e["dur"] == 1 for e in bundles)
        stalls = Counter()
        for e in mine:
            if e["cat"] == "stall":
                stalls[e["name"]] += e["dur"]
        assert stalls == Counter(procs[p]["stalls"])
        # slices of one track never overlap (a cycle issues or stalls, once)
        spans = sorted((e["ts"], e["ts"] + e["dur"]) for e in mine)
        assert all(a[1] <= b[0] for a, b in zip(spans, spans[1:]))
    misses = [e for e in events if e["ph"] == "i"]
    assert all(e["name"] == "cache_miss" for e in misses)
    for p in ("pe0.ic", "pe0.sc"):  # IC and SC read their global memory through a cache
        mine = [e for e in misses if e["tid"] == THREADS[p]]
        assert len(mine) == stats["memory"][p]["cache"]["misses"] > 0
    assert {e["args"]["region"] for e in misses if e["tid"] == 1} == {"shape_data",
                                                                      "primitive_list"}
    last = {}
    for e in sorted((e for e in events if e["ph"] == "C"), key=lambda e: e["ts"]):
        assert 0 <= e["args"]["words"] <= stats["fifos"][e["name"]]["capacity"]
        last[e["name"]] = e["args"]["words"]
    assert {"pe0.host", "pe0.recv.ic", "pe0.col"} <= set(last)
    assert all(last[n] == stats["fifos"][n]["left"] for n in last)


# ---------------------------------------------------------------------------------------------
# A window in the middle of the run: the engine runs to it, the reference engine steps it


def test_window_matches_the_reference_trace(tmp_path, engine_name, capsys):
    first, end = WINDOW
    kanata, trace_json = tmp_path / "w.log", tmp_path / "w.json"
    code, stats = render(tmp_path, engine_name, "--timeline", str(kanata), "--cycles",
                         f"{first}:{end}")
    if engine_name == "tandem":
        assert tandem_refused(code, capsys)
        return
    assert code == 0 and stats["run"]["cycles"] > end
    # the statistics and the image are those of a run without a timeline
    trace, plain = reference_run(first, end)
    assert without_engine(stats) == without_engine(plain) and "image_sha256" in plain
    assert stats["run"]["engine"] == engine_name
    threads = {t: p for p, t in THREADS.items()}
    want = sorted((c, q, pc) for c, q, pc, what in trace
                  if not what.startswith(("stall", "halted")))
    want_stalls = {(q, c): (pc, what.removeprefix("stall "))
                   for c, q, pc, what in trace if what.startswith("stall")}
    # Kanata: the issued bundles (cycle, processor, pc) are the trace's, once each
    rows = read_kanata(kanata.read_text())
    got = sorted((issue_cycle(r), threads[r.thread], r.sim_id) for r in rows if not r.flushed)
    assert got == want
    # every stall line is one lane-1 stage cycle of its cause, on a row of its PC
    stalls = {}
    for r in rows:
        for name, s, e in r.lanes.get(1, []):
            for c in range(s, e):
                key = (threads[r.thread], c)
                assert key not in stalls, f"two stalls at {key}"
                stalls[key] = (r.sim_id, name)
    assert stalls == want_stalls
    # flushed rows: a hold carried into the window, or a bundle still waiting at its end
    flushed = [r for r in rows if r.flushed]
    assert flushed
    for r in flushed:
        names = {s[0] for s in r.lanes[1]}
        assert 0 not in r.lanes and (names <= HOLD_CAUSES or not names & HOLD_CAUSES)
        assert r.lanes[1][0][1] == first or r.lanes[1][-1][2] == end
    # the JSON of the same window: the same bundles and stall cycles
    assert render(tmp_path, engine_name, "--timeline", str(trace_json), "--cycles",
                  f"{first}:{end}")[0] == 0
    events = check_trace_events(json.loads(trace_json.read_text()))
    timed = [e for e in events if e["ph"] in ("X", "i")]
    assert min(e["ts"] for e in timed) == first
    assert max(e["ts"] + e.get("dur", 1) for e in timed) == end
    issued = sorted((e["ts"], threads[e["tid"]], e["args"]["pc"]) for e in timed
                    if e["ph"] == "X" and e["cat"] == "bundle")
    assert issued == want
    spans = {}
    for e in timed:
        if e["ph"] == "X" and e["cat"] == "stall":
            for c in range(e["ts"], e["ts"] + e["dur"]):
                spans[(threads[e["tid"]], c)] = (e["args"]["pc"], e["name"])
    assert spans == want_stalls


@pytest.mark.slow
def test_timeline_files_do_not_depend_on_the_engine_before_the_window(tmp_path):
    """The window is stepped by the reference engine from the state the engine reached: the
    compiled engine's hand-off gives the same files byte for byte."""
    files = {}
    for engine in ("reference", "compiled"):
        for suffix in ("kanata", "json"):
            path = tmp_path / f"{engine}.{suffix}"
            assert render(tmp_path, engine, "--timeline", str(path), "--cycles", "3000:4000",
                          name=engine)[0] == 0
            files[engine, suffix] = path.read_bytes()
    for suffix in ("kanata", "json"):
        assert files["reference", suffix] == files["compiled", suffix]


# ---------------------------------------------------------------------------------------------
# run --timeline on a tiny program, and bad input


IC_SRC = """
start:
    ldg r1, [r0 + 1]
    fadd r2, r1, r1
    fmul r3, r2, r2
    halt
"""


@pytest.fixture
def tiny(tmp_path):
    (tmp_path / "ic.s").write_text(IC_SRC)
    (tmp_path / "img.json").write_text(json.dumps({"icgm": [0.5, 1.25, 2.0]}))

    def run(*extra: str) -> int:
        return main(["run", "--ic", str(tmp_path / "ic.s"), "--image",
                     str(tmp_path / "img.json"), "-q", *extra])
    return run


def test_run_timeline_of_a_tiny_program(tmp_path, tiny, engine_name, capsys):
    path = tmp_path / "t.kanata"
    code = tiny("--engine", engine_name, "--timeline", str(path))
    if engine_name == "tandem":
        assert tandem_refused(code, capsys)
        return
    assert code == 0
    rows = read_kanata(path.read_text())
    assert [(r.sim_id, issue_cycle(r), r.flushed) for r in rows] == [
        (0, 0, False), (1, 8, False), (2, 10, False), (3, 11, False)]
    ldg, fadd, fmul, halt = rows
    assert ldg.lanes[1] == [["cache_miss", 1, 8]]  # the miss holds issue: t_g = 8
    assert ldg.lanes[2] == [["X.ldg", 0, 8], ["Wb", 8, 9]]
    assert fmul.lanes[1] == [["operand:fadd", 9, 10]]  # waits for fadd's r2 (latency 2)
    # wake-up arrows: fadd waited for the ldg's r1 (its row opened at 8, r1 written at 8),
    # fmul for fadd's r2; the halt reads nothing
    assert (ldg.producers, fadd.producers, fmul.producers, halt.producers) == ([], [0], [1], [])
    assert "issued at cycle 10; stalls: operand:fadd 1" in fmul.detail
    assert ldg.label == "pe0.ic    0 start: ldg r1, [1]"  # the assembler prints it so
    # a window from cycle 9: the fadd's result is written in it, the ldg's hold is behind it
    code = tiny("--engine", engine_name, "--timeline", str(path), "--cycles", "9:")
    assert code == 0
    rows = read_kanata(path.read_text())
    assert [(r.sim_id, r.flushed) for r in rows] == [(2, False), (3, False)]
    assert rows[0].lanes[1] == [["operand:fadd", 9, 10]]


def test_procs_chooses_the_rows(tmp_path, tiny):
    path = tmp_path / "pe1.kanata"
    assert tiny("--pes", "2", "--timeline", str(path), "--procs", "pe1") == 0
    rows = read_kanata(path.read_text())
    assert len(rows) == 4 and {r.thread for r in rows} == {4}  # pe1.ic: pe0.os, .ic, .sc, pe1.os
    assert all(r.label.startswith("pe1.ic ") for r in rows)


def test_default_window_says_so_when_the_run_goes_on(tmp_path, tiny, capsys, monkeypatch):
    from netsushisen import timeline

    monkeypatch.setattr(timeline, "DEFAULT_WINDOW", 9)
    path = tmp_path / "d.json"
    assert tiny("--timeline", str(path)) == 0
    events = check_trace_events(json.loads(path.read_text()))
    assert [e["ts"] for e in events if e.get("cat") == "bundle"] == [0, 8]
    err = capsys.readouterr().err
    assert "cycles 0 to 9" in err and "the default window of 9 cycles" in err
    assert "run went on to cycle 12" in err and "--cycles A:B" in err


def test_window_after_the_run_is_an_empty_valid_file(tmp_path, tiny, capsys):
    path = tmp_path / "late.kanata"
    assert tiny("--timeline", str(path), "--cycles", "100:200") == 0
    assert path.read_text() == "Kanata\t0004\nC=\t12\n"
    assert read_kanata(path.read_text()) == []
    assert "empty: the run stopped at cycle 12, before the window" in capsys.readouterr().err


@pytest.mark.parametrize("extra, message", [
    (["--timeline", "t.txt"], "the extension says the format"),
    (["--timeline", "t.json", "--cycles", "0:2000000"], "at most 1,000,000 cycles"),
    (["--timeline", "t.json", "--cycles", "5:5"], "the window is empty"),
    (["--timeline", "t.json", "--cycles", "x:9"], "expected A:B"),
    (["--timeline", "t.json", "--procs", "pe3.ic"], "--procs pe3.ic: no such processor"),
    (["--procs", "pe0.ic"], "--procs pe0.ic: it chooses what a --timeline shows"),
    (["--timeline", "no/such/dir/t.json"], "--timeline no/such/dir/t.json:"),
    (["--timeline", "t.json", "--trace"], "choose one"),
])
def test_bad_timeline_requests_are_one_line_errors(tmp_path, tiny, monkeypatch, capsys, extra,
                                                   message):
    monkeypatch.chdir(tmp_path)
    code = tiny("--json", "s.json", *extra)
    err = capsys.readouterr().err
    assert code == 1 and message in err
    assert "Traceback" not in err and len(err.strip().splitlines()) == 1
    assert not (tmp_path / "s.json").exists()  # refused before the run
    assert not (tmp_path / "t.txt").exists()


@pytest.mark.parametrize("extra, message", [
    (["--timeline", "t.perfetto"], "--timeline t.perfetto: the extension says the format"),
    (["--cycles", "0:100"], "--cycles 0:100: it chooses what a --timeline shows"),
])
def test_render_refuses_bad_timeline_options_before_work(tmp_path, monkeypatch, capsys, extra,
                                                         message):
    monkeypatch.chdir(tmp_path)
    assert main(TETRA + extra) == 1
    assert message in capsys.readouterr().err
    assert list(tmp_path.iterdir()) == []


LOOP_SRC = """
start:
    addi r1, r1, 1
    j start
"""


def test_ctrl_c_in_the_window_closes_a_valid_timeline(tmp_path, monkeypatch, capsys):
    """Ctrl-C while the window is stepped: the run ends "interrupted" (exit 130) with its
    statistics, and the timeline is whole up to the cycle reached."""
    from netsushisen.progress import RunMonitor

    plain = RunMonitor.progress

    def progress(self, cycle: int) -> None:
        if cycle >= 4_000:
            self.requested = True  # as the SIGINT handler does
        plain(self, cycle)

    monkeypatch.setattr(RunMonitor, "progress", progress)
    (tmp_path / "loop.s").write_text(LOOP_SRC)
    path, stats = tmp_path / "i.kanata", tmp_path / "s.json"
    code = main(["run", "--ic", str(tmp_path / "loop.s"), "-q", "--timeline", str(path),
                 "--cycles", "1000:9000", "--json", str(stats)])
    assert code == 130
    assert json.loads(stats.read_text())["run"]["status"] == "interrupted"
    rows = read_kanata(path.read_text())
    issued = [issue_cycle(r) for r in rows if not r.flushed]
    assert issued and issued[0] >= 1_000 and max(issued) == 3_999
    assert "cycles 1,000 to 4,000" in capsys.readouterr().err
