"""The Python API: what the commands do, as functions returning result objects (docs/api.md).

    import netsushisen as nss

    r = nss.render("tetra", res=32, set={"ic.latency.fmul": 6})
    r.image, r.ids, r.rays, r.stats          # uint8 H×W×3, hit ids, ray counts, statistics
    r.table("ilp")                           # a pandas DataFrame: `report ilp --format csv`

Each function is the command's path, not a second one: `render` is the render pipeline
(`netsushisen.pipeline`, what `netsushisen render` runs), `golden` the golden model, `run` the
engine interface, `assemble` the assembler, `scene` the scene catalog, `Config` the machine
configuration (`isa/config.py`), `load_stats` the reports' reader (JSON or a flat dump), and a
result's `.table(name)` the report's own sections, so its DataFrame has the CSV output's columns.
Bad input raises `NetsushisenError` with the message the command line would print.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from netsushisen.isa.errors import NetsushisenError
from netsushisen.isa.config import MachineConfig, load_config, override_items

if TYPE_CHECKING:
    import pandas

    from netsushisen.asm.objects import Program
    from netsushisen.host.scenes import Scene
    from netsushisen.isa.images import MemoryImage

Config = MachineConfig
"""The machine configuration: `Config()` the defaults, `Config.load(path, overrides)` a TOML
file, `config.with_({"ic.latency.fmul": 6}, pes=4)` a changed copy (set paths as `--set`)."""


@dataclass
class Results:
    """What a run gives: the statistics document (`stats`, as `--json` writes it) and, when
    the run made a picture, the image (H×W×3 uint8), the hit ids (H×W int32, −1 background) and
    the ray counts by kind."""

    stats: dict
    image: np.ndarray | None = None
    ids: np.ndarray | None = None
    rays: dict[str, int] | None = None
    extra: dict[str, Any] = field(default_factory=dict)
    """What else the run returned: `engine` (the engine object, to read registers and
    memories), `frame` (the raw frame buffer of `run`), `golden` (the golden model's result)."""

    @property
    def status(self) -> str | None:
        """How the run ended (`run.status`): halted, finished, fault, deadlock, ..."""
        return (self.stats.get("run") or {}).get("status")

    def tables(self, report: str, **options) -> dict[str, pandas.DataFrame]:
        """Every table of report `report` (ilp, stalls, memory, annotate, ...) by its key."""
        import pandas as pd

        from netsushisen.reports.tables import report_sections

        if "processors" not in self.stats:
            raise NetsushisenError(f"no machine statistics to report on (report {report!r} "
                                   "reads a machine run's statistics; the golden model's are "
                                   "its own)")
        return {s.key: pd.DataFrame(s.rows, columns=s.columns)
                for s in report_sections(report, self.stats, **options)}

    def table(self, name: str, **options) -> pandas.DataFrame:
        """One report table as a DataFrame whose columns are the CSV output's: `"ilp"` (the
        report's first table) or `"ilp.slot_fill"` (a table by its key, as `--table`);
        `options` are the report's (`top=`, `proc=`, `order=`, ...)."""
        report, _, key = name.partition(".")
        tables = self.tables(report, **options)
        if not key:
            return next(iter(tables.values()))
        if key not in tables:
            raise NetsushisenError(f"report {report} has no table {key!r} (tables: "
                                   f"{', '.join(tables)})")
        return tables[key]

    def flat(self) -> str:
        """The statistics as `report flat` prints them."""
        from netsushisen.reports.flat import format_flat

        return format_flat(self.stats)

    def save(self, path: str | Path) -> None:
        """Write the statistics as JSON (as `--json` does), readable by `load_stats`."""
        from netsushisen.emulator.stats import dumps

        from netsushisen.isa.outputs import write_text

        write_text(path, dumps(self.stats))


def _document(stats: dict) -> dict:
    """The statistics as the `--json` file holds them (keys sorted, as `load_stats` reads them
    back), so a result's tables are the same as the report's on that file."""
    import json

    from netsushisen.emulator.stats import dumps

    return json.loads(dumps(stats))


def _config(config: MachineConfig | str | Path | None, sets: dict | list | None,
            **shorthands: Any) -> MachineConfig:
    """A configuration (or a TOML file, or the defaults) with `set` and the shorthands
    (`pes=`, `precision=`, `depth=`, `max_cycles=`: the command line's, options.SHORTHANDS)."""
    from netsushisen.options import SHORTHANDS

    items = override_items(sets)
    items += [f"{SHORTHANDS[k][1]}={v}" for k, v in shorthands.items() if v is not None]
    if isinstance(config, MachineConfig):
        return config.with_(items)
    return load_config(config, items)


def scene(name_or_path: str | Path) -> Scene:
    """A built-in SPD scene (`tetra`, `balls:2`, ...) or an `.nff` file."""
    from netsushisen.host.catalog import load_scene

    return load_scene(str(name_or_path))


def assemble(source: str | Path, proc: str | None = None,
             defines: dict[str, int | float] | None = None) -> Program:
    """Assemble a kernel: `source` is a `.s` file's path or the source text itself (any text
    with a newline); `proc` os, ic or sc (default: the source's `.proc`)."""
    from netsushisen.asm.assembler import assemble_file, assemble_text

    if isinstance(source, Path) or "\n" not in source:
        return assemble_file(source, proc=proc, defines=defines)
    return assemble_text(source, proc=proc, defines=defines)


def render(scene: str | Path | Scene, res: int = 32, pes: int | None = None,
           precision: str | None = None, set: dict | list | None = None,  # noqa: A002
           engine: str | None = None, kernels: str | Path | None = None,
           config: MachineConfig | str | Path | None = None, depth: int | None = None,
           max_cycles: int | None = None, corners: bool = False, generic: bool = False,
           slots: int | None = None, progress=None) -> Results:
    """Render `scene` on the emulated machine, as `netsushisen render` does: `set` holds
    configuration overrides (`{"ic.latency.fmul": 6}`), `kernels` a folder of your own os.s,
    ic.s, sc.s, `engine` reference, compiled or tandem (default: compiled, or reference where
    numba does not import)."""
    from netsushisen import pipeline
    from netsushisen.emulator.engine import check_engine, default_engine
    from netsushisen.options import check_footprint, check_resolution

    check_resolution(res)
    cfg = _config(config, set, pes=pes, precision=precision, depth=depth, max_cycles=max_cycles)
    name = check_engine(engine) if engine else default_engine()
    check_footprint("render", cfg, res + 1 if corners else res, name, quiet=True)
    s = scene if not isinstance(scene, Path) else str(scene)
    result = pipeline.render(s, cfg, res, corners, generic,
                             pipeline.DEFAULT_SLOTS if slots is None else slots, kernels,
                             progress=progress, engine=name)
    return Results(_document(result.stats), result.image_u8, result.hit_ids, dict(result.rays),
                   {"engine": result.engine})


def golden(scene: str | Path | Scene, res: int = 64, precision: str | None = None,
           set: dict | list | None = None,  # noqa: A002
           config: MachineConfig | str | Path | None = None, depth: int | None = None,
           corners: bool = False) -> Results:
    """Render `scene` with the golden numpy model, as `netsushisen golden` does; `stats` holds
    its figures (`--json`'s document)."""
    from netsushisen.host.catalog import load_scene
    from netsushisen.host.golden import render as golden_render
    from netsushisen.options import check_footprint, check_resolution

    check_resolution(res)
    cfg = _config(config, set, precision=precision, depth=depth)
    check_footprint("golden", None, res + 1 if corners else res, None, golden=True, quiet=True)
    sc = scene if not isinstance(scene, (str, Path)) else load_scene(str(scene))
    result = golden_render(sc, cfg, res=res, corners=corners)
    stats = {"scene": sc.name, "res": res, "corners": corners, "precision": result.precision,
             "primitives": sc.n_primitives, "visible_primitives": result.visible_primitives,
             "rays": dict(result.rays), "references": result.total_references,
             "seconds": round(result.seconds, 3)}
    return Results(stats, result.image_u8, result.hit_ids, dict(result.rays), {"golden": result})


def run(programs: dict[str, Program | str | Path] | list[Program],
        image: MemoryImage | str | Path | None = None,
        config: MachineConfig | str | Path | None = None, engine: str | None = None,
        set: dict | list | None = None,  # noqa: A002
        max_cycles: int | None = None, defines: dict[str, int | float] | None = None) -> Results:
    """Run programs on the machine, as `netsushisen run` does: `programs` by stage (`{"ic":
    program}`; a program, an object file or a `.s` source) or a list of programs (each names its
    processor); `image` a memory image (or its file). The frame buffer, if the run wrote one, is
    `.image` (8-bit) and `extra["frame"]` (raw)."""
    from netsushisen.emulator.engine import check_engine, default_engine, make_engine
    from netsushisen.host.golden import to_u8
    from netsushisen.isa.images import load_image
    from netsushisen.isa.processors import STAGES
    from netsushisen.options import load_program

    if isinstance(programs, (list, tuple)):
        programs = {p.proc: p for p in programs}
    unknown = [s for s in programs if s not in STAGES]
    if unknown:
        raise NetsushisenError(f"no processor {unknown[0]!r} (processors: {', '.join(STAGES)})")
    progs = {s: None for s in STAGES}
    for stage, p in programs.items():
        progs[stage] = load_program(str(p), stage, defines or {}) if isinstance(p, (str, Path)) else p
    if isinstance(image, (str, Path)):
        image = load_image(image)
    cfg = _config(config, set, max_cycles=max_cycles)
    eng = make_engine(check_engine(engine) if engine else default_engine(), cfg, progs, image)
    eng.run()
    frame = np.asarray(eng.frame)
    return Results(_document(eng.statistics()), to_u8(frame) if frame.size else None,
                   np.array(eng.ids, copy=True) if frame.size else None, None,
                   {"engine": eng, "frame": frame})


def load_stats(path: str | Path) -> Results:
    """A statistics file (`--json`, or a `report flat` dump) as results: `.stats`, `.table()`."""
    from netsushisen.reports.tables import load_stats as read

    return Results(read(path))
