"""`netsushisen paper`: the trace-driven path against the full model and against the
cycle-accurate emulator (the stage kernels' serial mode); the tables, findings, figures and CSV
files."""

from __future__ import annotations

import copy
import csv
from pathlib import Path

import numpy as np
import pytest

from netsushisen.host.catalog import load_scene
from netsushisen.host.databases import GLOBAL, RESIDENT, build_images
from netsushisen.host.golden import render as golden_render
from netsushisen.host.grid import build_grid
from netsushisen.host.prepass import run_prepass
from netsushisen.isa.config import load_config
from netsushisen.kernels import KERNELS
from netsushisen.reports import paper as paper_mod
from netsushisen.reports.paper import table2
from netsushisen.paper_machine import PAPER_ORDER
from netsushisen.emulator.tracesim import TraceMemory
from netsushisen.host.ic_access import machine_order, ordered_stream_chunks
from netsushisen.paper import analyse_scene, compare_counters
from netsushisen.reports.paper_data import PaperOptions

# ------------------------------------------------------------------------------------------------
# End to end: the trace-driven path equals the emulator's counters (needs the stage kernels)

def _needs_kernels() -> None:
    """The stage kernels and their serial mode (SERIAL_TREES=1) exist: one gone missing is a
    failure here, not a skip (a regression must not pass unseen)."""
    assert (KERNELS / "os.s").exists(), "kernels/os.s is missing: the emulator cannot render"
    sources = [*KERNELS.glob("*.s"), *KERNELS.glob("*.inc")]
    assert any("SERIAL_TREES" in f.read_text(encoding="utf-8", errors="replace") for f in sources), \
        ("the kernels have no serial mode (no SERIAL_TREES in kernels/): only with one ray tree "
         "in flight does the machine visit rays in the trace-driven model's order")


def trace_driven_counters(setup) -> dict:
    """IC's memory counters from the golden trace in machine order, for a render setup's images."""
    golden = golden_render(setup.scene, setup.config, res=setup.res, corners=setup.corners,
                           keep_trace=True, grid=setup.images.layout.grid)
    model = TraceMemory.for_images(setup.images)
    for space, address in ordered_stream_chunks(setup.images.layout, golden, machine_order(golden)):
        model.replay(space, address)
    return model.stats()


def check_emulator_equals_trace(scene: str, res: int, sets: tuple[str, ...] = ()) -> None:
    _needs_kernels()
    from netsushisen.pipeline import render

    config = load_config(None, list(sets))
    r = render(scene, config, res=res, slots=1, defines={"SERIAL_TREES": 1})
    assert r.run.status in ("halted", "finished"), r.run
    assert compare_counters(trace_driven_counters(r.setup), r.stats["memory"]["pe0.ic"]) == ""


# Small memories: at 8x8 the default 8 KB cache holds mount:2's whole database (cold misses
# only), so only the small split makes the counters depend on the order of the references.
@pytest.mark.parametrize("sets", [(), ("ic_memory.cache_share=0.1", "ic_memory.resident_share=0.1")],
                         ids=["default", "small-memories"])
def test_trace_driven_path_equals_the_emulator_small(sets):
    check_emulator_equals_trace("mount:2", 8, sets)  # reflective and transparent: branching ray trees


def test_serial_mode_ic_loads_follow_machine_order():
    """Stronger than equal counters: in serial mode IC's resident and global loads are, one by
    one, the golden trace's IC access stream in `machine_order` (each pixel's ray tree in level
    order) — and in normal mode with the same kernels' load order (PAPER_ORDER) they are the same
    loads in another order."""
    _needs_kernels()
    from netsushisen.pipeline import prepare

    def ic_loads(setup) -> list[tuple[int, int]]:
        machine = setup.machine()
        ic = machine.pes[0].cores["ic"]
        ic.events = []  # record IC's events only
        loads = []
        while machine.step() is None:
            loads += [(RESIDENT if e[2] == "resident" else GLOBAL, e[3]) for e in ic.events
                      if e[0] == "load" and e[2] in ("resident", "global")]
            ic.events.clear()
        assert machine.status == "finished", machine.error
        return loads

    config = load_config()
    setup = prepare("mount:2", config, res=6, slots=1, defines={"SERIAL_TREES": 1})
    golden = golden_render(setup.scene, setup.config, res=6, keep_trace=True, grid=setup.images.layout.grid)
    want = [(s, a) for space, address in ordered_stream_chunks(setup.images.layout, golden, machine_order(golden))
            for s, a in zip(space.tolist(), address.tolist())]
    assert ic_loads(setup) == want
    normal = ic_loads(prepare("mount:2", config, res=6, slots=8, defines=PAPER_ORDER))
    assert sorted(normal) == sorted(want) and normal != want


@pytest.mark.slow
@pytest.mark.parametrize("scene", ["tetra", "balls", "mount", "rings"])
def test_trace_driven_path_equals_the_emulator_32(scene):
    check_emulator_equals_trace(scene, 32)


# ------------------------------------------------------------------------------------------------
# The paper path against the full trace-driven model


@pytest.fixture(scope="module")
def small():
    """The machine's reading: lists + records sized, list cells through the cache (what the
    IC kernel does), so every sweep point is a machine configuration."""
    config = load_config()
    return analyse_scene("mount:3", 16, config, options=PaperOptions("records+lists", "cache")), config


def test_sweep_points_equal_the_full_model(small):
    data, config = small
    scene = load_scene("mount:3")
    grid = build_grid(scene, config)
    pre = run_prepass(scene, config, res=16, grid=grid)
    golden = golden_render(scene, config, res=16, keep_trace=True, grid=grid)
    order = machine_order(golden)
    checked = 0
    for row in data.fig5:
        if (row["local_share"], row["resident_split"]) not in ((0.3, 0.0), (0.3, 0.5), (0.5, 0.8), (0.1, 1.0)):
            continue
        L, r = row["local_share"], row["resident_split"]
        cfg = load_config(None, [f"ic_memory.resident_share={L * r}", f"ic_memory.cache_share={L * (1 - r)}"])
        im = build_images(scene, cfg, priorities=pre.priorities, grid=grid)
        model = TraceMemory.for_images(im)
        for s, a in ordered_stream_chunks(im.layout, golden, order):
            model.replay(s, a)
        st = model.stats()
        res = st["resident"]["accesses"]
        acc, hits = st["cache"]["accesses"], st["cache"]["hits"]
        assert row["all"]["resident"] == res and row["all"]["cache_accesses"] == acc
        assert row["all"]["cache_hits"] == hits
        assert row["resident_count"] == im.layout.resident_count
        t = (res * 1 + hits * 2 + (acc - hits) * 8) / (res + acc)
        assert row["all"]["t_measured"] == pytest.approx(t)
        assert row["all"]["t_model"] == pytest.approx(t)  # the paper's formula is exact for 1:2:8
        checked += 1
    assert checked == 4


def test_table2_and_locality_from_the_golden_model(small):
    data, config = small
    g = golden_render(load_scene("mount:3"), config, res=16)
    vis = np.unique(g.hit_ids[g.hit_ids >= 0])
    row = table2([data])[0]
    assert row["visible_ours"] == len(vis) == g.visible_primitives
    assert row["visible_share_ours"] == pytest.approx(len(vis) / len(g.references))
    assert row["reference_share_ours"] == pytest.approx(g.references[vis].sum() / g.references.sum())
    f, c = data.locality()
    assert c[0] == 0 and c[-1] == pytest.approx(1) and np.all(np.diff(c) >= 0) and np.all(np.diff(np.diff(c)) <= 1e-12)
    assert data.unreferenced_share == pytest.approx(np.mean(g.references == 0))
    # Figure 5 at resident 0 is Figure 4's cache-only point of the same size
    fig4 = {r["cache_share"]: r["all"]["t_measured"] for r in data.fig4}
    for r in data.fig5:
        if r["resident_split"] == 0:
            assert r["all"]["t_measured"] == fig4[r["local_share"]]


def test_paper_defaults_count_per_reference_against_the_records(small):
    """The paper's reading (default options): local memory sized against the shape records,
    list cells outside the cache; one reference per intersection test."""
    _, config = small
    d = analyse_scene("mount:3", 16, config)
    assert d.options == PaperOptions()
    assert d.primitive_database_bytes == d.database_bytes["shape_data"]
    tests = int(d.references.sum())
    for r in d.fig4 + d.fig5:
        assert r["ref"]["loads"] == tests
        assert r["all"]["loads"] > tests  # several words per test
    cache_only = d.fig4[-1]
    assert cache_only["ref"]["miss_rate"] > cache_only["all"]["miss_rate"]  # a reference misses if any word does
    # no cache at a 100 % resident split: with the lists local, every cache access is a
    # non-resident record's, and each costs t_g
    full = [r for r in d.fig5 if r["resident_split"] == 1.0 and r["local_share"] == 0.5][0]
    f = full["ref"]
    assert full["cache_bytes"] == 0 and f["cache_hits"] == 0 and 0 < f["resident"] < tests
    assert f["t_measured"] == pytest.approx((f["resident"] + 8 * f["cache_accesses"]) / tests)
    assert full["all"]["cache_accesses"] == full["shape"]["cache_accesses"]  # no list read is cached


# ------------------------------------------------------------------------------------------------
# The command


def test_paper_command_writes_report_figures_and_csvs(tmp_path, cli):
    out = tmp_path / "p"
    code, stdout, err = cli("paper", "--res", "8", "--scenes", "tetra:1", "mount:2", "--out", out, "--quiet")
    assert code == 0, err
    for name in ("fig3_locality.png", "fig4_miss_rate.png", "fig5_access_time.png",
                 "fig5_access_time_per_word.png", "fig5_rho_miss_rate.png"):
        assert (out / name).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    with (out / "fig4_miss_rate.csv").open() as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == 20 and {r["scene"] for r in rows} == {"tetra", "mount"}
    with (out / "fig5_access_time.csv").open() as f:
        assert len(list(csv.DictReader(f))) == 2 * 3 * 11
    for name in ("table1.csv", "table2.csv", "fig3_locality.csv"):
        assert (out / name).stat().st_size > 0
    md = (out / "report.md").read_text()
    assert "## Table 1" in md and "## Table 2" in md and "![Figure 5](fig5_access_time.png)" in md
    assert "Figure 5: for 10 % local memory t rises with the resident share" in md
    assert "tetra 4096 polygons" in md and "tetra | 4 (paper 2121)" not in md
    assert "per primitive reference (the paper's counting):" in md and "- per word:" in md
    assert md.count("*Test:*") == 24 and "Why these defaults are the paper's" in md
    # every judged finding; "not evaluated" here: §4.3 and the two scene orderings (4 scenes)
    assert md.count("*Margin:*") == 21 and md.count("**Not evaluated.**") == 3
    assert "§4.3: the pre-pass costs about 1 % of the main pass.** *Test:* one-sided" in md
    assert "(`prepass.share = 0.01`, as the paper's)" in md
    assert "--sizing records --lists local" in md
    # a differing Figure 4–5 finding was rerun under every trace-driven candidate, the PE split
    # among them; the machine's ray order needs --on-machine and says so
    assert "candidates run — " in md and "4 PEs: " in md
    assert "not run: the machine's normal ray order (`--on-machine`)" in md


@pytest.mark.heavy  # [reference] under -m slow (tests/conftest.py)
def test_paper_on_machine_checks_the_counters(tmp_path, cli, engine_name):
    """--on-machine renders each scene on the machine (serial mode) in worker processes and
    finds IC's counters equal to the trace-driven path's."""
    _needs_kernels()
    out = tmp_path / "p"
    code, stdout, err = cli("paper", "--res", "4", "--scenes", "mount:2", "--out", out,
                            "--on-machine", "--engine", engine_name, "--jobs", "2")
    assert code == 0, err
    assert "per-reference counts equal the trace-driven path's for mount" in stdout
    md = (out / "report.md").read_text()
    assert "## On the machine" in md and "**All counters equal**" in md and f"{engine_name} engine" in md
    from netsushisen.paper import FINDINGS_POINT, MACHINE_POINTS

    # per-word counters and per-reference counts, for the default memory, each point, 4 PEs and
    # the findings' reading (lists local)
    assert md.count("| equal |") == 2 * (3 + len(MACHINE_POINTS))
    assert f"| mount | {FINDINGS_POINT} |" in md
    assert "| mount | default, 4 PEs |" in md and "*4 PEs*" in md
    assert "## Ray order (on the machine)" in md and "change verdict under the machine's normal" in md
    assert all(f"| mount | {label} |" in md for label, *_ in MACHINE_POINTS)
    assert "The pre-pass on the machine" in md and "§4.3: the pre-pass costs about 1 %" in md


def test_counter_comparison_names_the_first_difference():
    a = {"resident": {"accesses": 5}, "cache": {"hits": 3, "misses": 1}, "regions": {"global.shape_data": {"accesses": 4}}}
    b = copy.deepcopy(a)
    assert compare_counters(a, b) == ""
    b["regions"]["global.shape_data"]["accesses"] = 5
    assert compare_counters(a, b) == "regions.global.shape_data.accesses: trace-driven 4, machine 5"
    b = copy.deepcopy(a)
    del b["cache"]
    assert compare_counters(a, b).startswith("cache:")


# Ctrl-C (the finished scenes written): tests/test_cluster.py


@pytest.mark.parametrize("argv, message", [
    (["--scenes", "nosuchscene"], "cannot load scene"),
    (["--res", "0"], "--res 0"),
    (["--set", "ic_memory.block_bytes=48"], "block_bytes must be a power of two"),
    (["--jobs", "0"], "--workers 0"),
    (["--workers", "0"], "--workers 0"),
    (["--scheduler", "http://x:80"], "expected tcp://HOST:PORT"),
    (["--series", "32,x"], "give resolutions separated by commas"),
    (["--series", "32"], "give two or more different resolutions"),
    (["--series", "0,8"], "--res 0"),
])
def test_paper_bad_input_is_one_located_line(tmp_path, cli, argv, message):
    code, _, err = cli("paper", "--out", tmp_path / "p", "--quiet", *argv)
    assert code == 1 and message in err and "Traceback" not in err


def test_paper_tables_hold_the_papers_numbers():
    assert paper_mod.PAPER_TABLE2["mount"] == (1903, 0.23, 0.57)
    assert paper_mod.PAPER_TABLE1["rings"][4] == 4200
    assert Path(paper_mod.__file__).stat().st_size > 0


def test_trace_experiments_are_variants_of_the_main_pass():
    """Mailboxing tests each primitive at most once per ray; eye-only, no-shadow and depth-1
    variants keep a subset of the rays; all are counted from the reference trace."""
    from netsushisen.host.golden import SHADOW
    from netsushisen.paper import trace_experiments

    config = load_config()
    g = golden_render(load_scene("mount:2"), config, res=8, keep_trace=True)
    ex = trace_experiments(g)
    full = ex["as rendered"]
    assert np.array_equal(full, g.references)
    mail = ex["mailboxing (each primitive tested once per ray)"]
    assert np.all(mail <= full) and np.array_equal(mail > 0, full > 0) and mail.sum() < full.sum()
    off = g.trace_ray_offsets
    per_ray = np.diff(off)
    shadow_tests = int(per_ray[g.trace_kind == SHADOW].sum())
    assert int(ex["no shadow rays"].sum()) == int(full.sum()) - shadow_tests
    assert np.all(ex["eye rays only"] <= ex["ray-tree depth 1 (eye rays and their shadow rays)"])
    assert np.all(ex["ray-tree depth 1 (eye rays and their shadow rays)"] <= full)


def test_the_report_states_the_prepass_the_run_used():
    """The pre-pass sentence comes from the configuration and the rays shot: a full-resolution
    pre-pass is not "1 % of the main pass's eye rays, as the paper"."""
    from netsushisen.reports.paper_report import prepass_line
    from tests.test_paper_findings import scene

    d = scene("tetra")
    d.res, d.rays, d.prepass = 64, {"eye": 4096}, {"resolution": 64, "eye_rays": 4096}
    line = prepass_line(d, 1.0)
    assert "100.00 % of the main pass's eye rays" in line and "prepass.share = 1" in line
    assert "the paper's is about 1 %" in line and "full-resolution ranking" in line
    assert "as the paper" not in line.replace("as the paper's)", "")
    d.prepass = {"resolution": 6, "eye_rays": 36}
    line = prepass_line(d, 0.01)
    assert "0.88 % of the main pass's eye rays" in line and "as the paper's" in line
    assert "coarse ranking" in line


def test_the_series_lists_each_findings_measure_per_resolution_and_marks_provisional():
    """series.md: per finding the verdict, k/n and worst margin at each resolution, every
    verdict below 512 provisional, and the findings whose verdict moves named."""
    from netsushisen.reports.paper import findings
    from netsushisen.reports.paper_series import series_markdown, series_rows
    from tests.test_paper_findings import paper_world_t, world

    low = findings(world(t=lambda L, s: 2.0 + s), "ref")  # resident never beats cache-only
    high = findings(world(), "ref")
    md = series_markdown({64: low, 512: high}, "netsushisen paper --series 64,512")
    row = next(line for line in md.splitlines() if "resident memory beats" in line)
    cells = [c.strip() for c in row.split("|")]
    assert cells[3].startswith("differ (provisional), 0/8, worst -")
    assert cells[4].startswith("agree, 8/8, worst +") and "provisional" not in cells[4]
    assert cells[5] == "yes"
    moved = [r for r in series_rows({64: low, 512: high}) if r["changes"]]
    assert any(r["paper"].startswith("resident memory beats") for r in moved)
    assert f"**{len(moved)} of {len(high)} findings change verdict" in md
    assert paper_world_t(0.3, 0.7) < paper_world_t(0.3, 0.0)  # the world the cells came from


@pytest.mark.slow
def test_paper_series_runs_every_resolution_in_one_command(tmp_path, cli):
    out = tmp_path / "s"
    code, stdout, err = cli("paper", "--series", "4,8", "--scenes", "mount:2", "--out", out,
                            "--no-candidates", "--workers", "1")
    assert code == 0, err
    assert (out / "res-4" / "report.md").exists() and (out / "res-8" / "report.md").exists()
    md = (out / "series.md").read_text()
    assert "| 4×4 | 8×8 |" in md and "(provisional)" in md
    with (out / "series.csv").open() as f:
        rows = list(csv.DictReader(f))
    assert {r["res"] for r in rows} == {"4", "8"} and all(r["provisional"] == "True" for r in rows)
