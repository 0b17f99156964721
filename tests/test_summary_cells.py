"""The summary `render` prints at a narrow width (issue 42, item 7): stall causes under 0.5 %
are no top stalls, a `cause N%` item is never split across lines, the lists get their t model
as `report memory` gives it, and the progress line keeps its message whole at 80 columns."""

from __future__ import annotations

import io

from netsushisen.reports.memory import memory_sections
from netsushisen.reports.summary import memory_table, processor_table
from netsushisen.reports.tables import render_table


def _stats(stalls: dict[str, int]) -> dict:
    p = {"cycles": 1000, "ops": 900, "stall_cycles": sum(stalls.values()), "stalls": stalls}
    regions = {"resident.primitive_list": {"accesses": 30}, "global.primitive_list":
               {"accesses": 70, "hits": 50}, "resident.shape_data": {"accesses": 10},
               "global.shape_data": {"accesses": 10, "hits": 10}}
    return {"processors": {"pe0.ic": p}, "programs": {},
            "memory": {"pe0.ic": {"regions": regions}},
            "config": {"ic_memory": {"t_r": 2, "t_c": 4, "t_g": 16}}}


def test_small_causes_are_dropped_and_items_stay_whole():
    stats = _stats({"cache_miss": 120, "operand:fmul_long_name": 118, "write_port": 4,
                    "branch": 60})
    row = processor_table(stats).rows[0]
    assert row[-1] == "cache_miss 12%, operand:fmul_long_name 12%, branch 6%"
    assert "write_port" not in processor_table(_stats({"write_port": 4, "branch": 5})).rows[0][-1]
    assert processor_table(_stats({"write_port": 5})).rows[0][-1] == "write_port 0%"  # 0.5 %
    for width in (60, 70, 80):
        text = render_table([processor_table(stats)], width)
        lines = text.splitlines()
        for item in ("cache_miss 12%", "operand:fmul_long_name 12%", "branch 6%"):
            assert any(item in line for line in lines), (width, text)


def test_the_lists_t_model_is_the_memory_reports():
    stats = _stats({})
    summary = {r[1]: r[-1] for r in memory_table(stats).rows}
    report = {r[1]: r[-1] for r in memory_sections(stats)[0].rows}
    assert summary["primitive_list"] is not None
    assert summary == {k: v for k, v in report.items() if k in summary}


def test_the_progress_line_keeps_compiling_whole_at_80_columns():
    from rich.console import Console

    from netsushisen.progress import COMPILING, RunMonitor

    class Compiling:  # an engine as far as the progress line reads one, still loading
        name = "compiled"

        def progress_counts(self):
            return 0, 0, 0

    monitor = RunMonitor(Compiling(), total=4096, label="tetra 64×64")
    monitor.console = Console(width=80, file=io.StringIO(), color_system=None)
    monitor._start_display()
    monitor._bar.stop()
    out = Console(width=80, file=io.StringIO(), color_system=None)
    out.print(monitor._bar.make_tasks_table(monitor._bar.tasks))
    line = out.file.getvalue().splitlines()[0]
    assert COMPILING in line and "compiling the engine" in COMPILING and len(line) <= 80
