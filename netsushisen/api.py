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

from netsushisen import arguments as arg
from netsushisen.isa.errors import Diagnostic, NetsushisenError
from netsushisen.isa.config import MachineConfig, load_config

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
        """Every table of report `report` (ilp, stalls, memory, annotate, bounds, diff) by its
        key; `options` are the report's (checked: each report lists the ones it takes)."""
        report = arg.choice("report", report, tuple(TABLE_OPTIONS), optional=False)
        if "processors" not in self.stats:
            raise NetsushisenError(f"no machine statistics to report on (report {report!r} "
                                   "reads a machine run's statistics; the golden model's are "
                                   "its own)")
        opts = arg.options(report, options, TABLE_OPTIONS[report])
        import pandas as pd

        from netsushisen.reports.tables import report_sections

        extra = ()
        if report == "diff":
            if "other" not in opts:
                raise arg.ArgumentError("report 'diff' takes other= (the results or the "
                                        "statistics file to compare with)")
            extra = (opts.pop("other"),)
        return {s.key: pd.DataFrame(s.rows, columns=s.columns)
                for s in report_sections(report, self.stats, *extra, **opts)}

    def table(self, name: str, **options) -> pandas.DataFrame:
        """One report table as a DataFrame whose columns are the CSV output's: `"ilp"` (the
        report's first table) or `"ilp.slot_fill"` (a table by its key, as `--table`);
        `options` are the report's (`top=`, `proc=`, `order=`, ...)."""
        name = arg.text("name", name)
        report, _, key = name.partition(".")
        tables = self.tables(report, **options)
        if not key:
            return next(iter(tables.values()))
        if key not in tables:
            raise NetsushisenError(f"report {report} has no table {key!r} (tables: "
                                   f"{', '.join(tables)})")
        return tables[key]

    def registers(self, proc: str) -> pandas.DataFrame:
        """The registers of processor `proc` (`"pe0.ic"`, or `"ic"` for PE 0's) at the end of
        the run, one row a register (`r0` ... as the index): its `.reg` names, the word as a
        signed integer, in hex and as the machine's float."""
        import pandas as pd

        from netsushisen.isa.words import word_format

        proc = arg.text("proc", proc)
        engine = self.extra.get("engine")
        if engine is None:
            raise NetsushisenError("these results carry no machine (registers are read from a "
                                   "run's engine: render or run, not golden or load_stats)")
        name = proc if "." in proc else f"pe0.{proc}"
        if name not in engine.processors():
            raise arg.ArgumentError(f"proc={proc!r}: proc takes a processor of this run "
                                    f"({', '.join(engine.processors())})")
        words = engine.registers(name)
        fmt = word_format(engine.config.precision)
        names: dict[int, list[str]] = {}
        core = next((c for c in getattr(engine.machine, "cores", ()) if c.name == name), None)
        program = getattr(core, "program", None)
        for rn in getattr(program, "reg_names", ()):
            if rn.name not in names.setdefault(rn.reg, []):
                names[rn.reg].append(rn.name)
        rows = [("/".join(names.get(i, [])), fmt.to_int(w), f"0x{w:0{2 * fmt.bytes}x}",
                 float(fmt.to_float(w))) for i, w in enumerate(words)]
        return pd.DataFrame(rows, columns=["name", "int", "hex", "float"],
                            index=[f"r{i}" for i in range(len(words))])

    def pipelining(self) -> pandas.DataFrame:
        """The software-pipelined loops of the run's assembled programs, one row a loop: its
        processor and name, operations, the minimum II and the II achieved, stages, whether it
        was pipelined and why not (`asm --stats`'s information)."""
        import pandas as pd

        columns = ["proc", "loop", "ops", "mii", "ii", "stages", "pipelined", "reason"]
        rows = [[stage] + [info[c] for c in columns[1:]]
                for stage, program in (self.extra.get("programs") or {}).items()
                for info in getattr(program, "pipelining", [])]
        return pd.DataFrame(rows, columns=columns)

    def summary(self) -> dict[str, Any]:
        """The few figures a glance wants: status, cycles, engine, image size."""
        run = self.stats.get("run") or {}
        out = {k: run[k] for k in ("status", "cycles", "engine") if k in run}
        for k in ("scene", "res", "precision"):
            if k in self.stats:
                out[k] = self.stats[k]
        if self.image is not None:
            out["image"] = "×".join(str(n) for n in self.image.shape[:2])
        return out

    def __repr__(self) -> str:
        """One short line (a statistics document is ~150,000 characters: never printed)."""
        inner = ", ".join(f"{k}={v!r}" if isinstance(v, str) else f"{k}={v}"
                          for k, v in self.summary().items())
        return f"Results({inner})"[:1000]

    def _repr_html_(self) -> str:
        """A notebook's view: the summary as a table and the image (a PNG, at most 512 pixels
        a side shown) beside it."""
        import base64
        import html

        rows = "".join(f"<tr><th style='text-align:left'>{html.escape(str(k))}</th>"
                       f"<td>{html.escape(str(v))}</td></tr>" for k, v in self.summary().items())
        picture = ""
        if self.image is not None and self.image.size:
            from netsushisen.host.images import encode_png

            png = base64.b64encode(encode_png(self.image)).decode("ascii")
            picture = (f"<img src='data:image/png;base64,{png}' style='image-rendering:"
                       "pixelated; width:256px; max-width:512px'/>")
        return f"<div><table>{rows}</table>{picture}</div>"

    def flat(self) -> str:
        """The statistics as `report flat` prints them."""
        from netsushisen.reports.flat import format_flat

        return format_flat(self.stats)

    def save(self, path: str | Path) -> None:
        """Write the statistics as JSON (as `--json` does), readable by `load_stats`."""
        from netsushisen.emulator.stats import dumps

        from netsushisen.isa.outputs import write_text

        write_text(arg.path("path", path), dumps(self.stats))


def _top(name: str, value: Any) -> int | None:
    return arg.integer(name, value, 0, 1 << 31, optional=True)


def _proc(name: str, value: Any) -> str | None:
    return arg.text(name, value, optional=True)


def _other(name: str, value: Any) -> dict:
    if isinstance(value, Results):
        return value.stats
    from netsushisen.reports.tables import load_stats as read

    return read(arg.path(name, value))


TABLE_OPTIONS: dict[str, dict[str, Any]] = {
    "ilp": {"top": _top},
    "stalls": {"top": _top, "explain": arg.flag},
    "memory": {},
    "annotate": {"proc": _proc, "top": _top,
                 "order": lambda n, v: arg.choice(n, v, ("hot", "program"), optional=False),
                 "all_loops": arg.flag},
    "bounds": {"proc": _proc, "top": _top,
               "optimum_ops": lambda n, v: arg.integer(n, v, 0, 1 << 31), "all_loops": arg.flag},
    "floor": {"proc": _proc},
    "diff": {"other": _other, "changed_only": arg.flag},
}
"""The reports `Results.table` reads (reports/tables.py REPORTS) and the keyword options each
takes, with their checks: a report added there is added here with its options."""


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

    config = arg.config(config)
    items = arg.overrides("set", sets)
    items += [f"{SHORTHANDS[k][1]}={v}" for k, v in shorthands.items() if v is not None]
    if isinstance(config, MachineConfig):
        return config.with_(items)
    return load_config(config, items)


def _res(name: str, value: Any) -> int:
    from netsushisen.options import MAX_RES

    return arg.integer(name, value, 1, MAX_RES)


def _scene(value: Any) -> Scene:
    """A Scene object, a built-in scene's name or an `.nff` file's path."""
    from netsushisen.host.catalog import load_scene
    from netsushisen.host.scenes import Scene

    if isinstance(value, Scene):
        return value
    if isinstance(value, str) or hasattr(value, "__fspath__"):
        return load_scene(arg.path("scene", value))
    raise arg.ArgumentError(f"scene={arg.shown(value)}: scene takes a scene's name ('tetra', "
                            f"'balls:2'), an .nff file's path or a nss.scene(...) object, not "
                            f"{type(value).__name__}")


def scene(name_or_path: str | Path) -> Scene:
    """A built-in SPD scene (`tetra`, `balls:2`, ...) or an `.nff` file."""
    from netsushisen.host.catalog import load_scene

    return load_scene(arg.path("name_or_path", name_or_path))


PROCS = ("os", "ic", "sc")


def _is_source_text(value: str) -> bool:
    """Source text rather than a file name: it has a newline or a directive/instruction shape
    no file name has."""
    return "\n" in value


def assemble(source: str | Path, proc: str | None = None,
             defines: dict[str, int | float] | None = None,
             config: MachineConfig | str | Path | None = None) -> Program:
    """Assemble a kernel: `source` is a `.s` file's path or the source text itself (any text
    with a newline); `proc` os, ic or sc (default: the source's `.proc`); `config` the machine
    the `.sched` regions are scheduled for (default: the defaults)."""
    if isinstance(source, (bytes, bytearray)):
        raise arg.ArgumentError(f"source={arg.shown(source)}: source takes a str (a .s file's "
                                "path or the source text), not bytes: decode it first")
    source = arg.path("source", source)
    proc = arg.choice("proc", proc, PROCS)
    symbols = arg.defines("defines", defines)
    cfg = _config(config, None) if config is not None else None
    return _assemble(source, proc, symbols, cfg)


def _assemble(source: str, proc: str | None, symbols: dict, cfg: MachineConfig | None) -> Program:
    """Source text or a `.s` file assembled, its software-pipelining information kept on the
    program as `pipelining` (the records of `asm --stats --json`)."""
    from netsushisen.asm.assembler import Assembler

    asm = Assembler(proc, symbols, None, cfg)
    program = (asm.assemble_text(source) if _is_source_text(source)
               else asm.assemble_file(source))
    program.pipelining = [r.as_dict() for r in asm.pipeline_reports]
    return program


def render(scene: str | Path | Scene, res: int = 32, pes: int | None = None,
           precision: str | None = None, set: dict | list | None = None,  # noqa: A002
           engine: str | None = None, kernels: str | Path | None = None,
           config: MachineConfig | str | Path | None = None, depth: int | None = None,
           max_cycles: int | None = None, corners: bool = False, generic: bool = False,
           slots: int | None = None, progress=None) -> Results:
    """Render `scene` on the emulated machine, as `netsushisen render` does: `set` holds
    configuration overrides (`{"ic.latency.fmul": 6}`), `kernels` a folder of your own os.s,
    ic.s, sc.s, `engine` reference, compiled or tandem (default: compiled, or reference where
    numba does not import). Every argument is checked before any work."""
    from netsushisen import pipeline
    from netsushisen.emulator.engine import check_engine, default_engine
    from netsushisen.options import check_footprint, check_resolution

    res = _res("res", res)
    check_resolution(res)
    corners, generic = arg.flag("corners", corners), arg.flag("generic", generic)
    slots = arg.integer("slots", slots, 1, 1 << 20, optional=True)
    kernels = arg.path("kernels", kernels, optional=True)
    engine = arg.text("engine", engine, optional=True)
    if progress is not None and not callable(progress):
        raise arg.ArgumentError(f"progress={arg.shown(progress)}: progress takes a callable or "
                                f"None, not {type(progress).__name__}")
    cfg = _config(config, set, pes=arg.integer("pes", pes, 1, optional=True),
                  precision=arg.choice("precision", precision, ("fp32", "fp64")),
                  depth=arg.integer("depth", depth, 1, optional=True),
                  max_cycles=arg.integer("max_cycles", max_cycles, 0, optional=True))
    name = check_engine(engine) if engine else default_engine()
    check_footprint("render", cfg, res + 1 if corners else res, name, quiet=True)
    s = _scene(scene)
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
    from netsushisen.host.golden import render as golden_render
    from netsushisen.options import check_footprint, check_resolution

    res = _res("res", res)
    check_resolution(res)
    corners = arg.flag("corners", corners)
    cfg = _config(config, set, precision=arg.choice("precision", precision, ("fp32", "fp64")),
                  depth=arg.integer("depth", depth, 1, optional=True))
    check_footprint("golden", None, res + 1 if corners else res, None, golden=True, quiet=True)
    sc = _scene(scene)
    result = golden_render(sc, cfg, res=res, corners=corners)
    stats = {"scene": sc.name, "res": res, "corners": corners, "precision": result.precision,
             "primitives": sc.n_primitives, "visible_primitives": result.visible_primitives,
             "rays": dict(result.rays), "references": result.total_references,
             "seconds": round(result.seconds, 3)}
    return Results(stats, result.image_u8, result.hit_ids, dict(result.rays), {"golden": result})


def _program(value: Any, stage: str | None, symbols: dict, cfg: MachineConfig,
             where: str) -> Program:
    """A Program, an object file's or a `.s` source's path, or source text, for `stage` (None:
    the program names its processor)."""
    from netsushisen.asm.objects import Program
    from netsushisen.options import load_program

    if isinstance(value, Program):
        program = value
    elif isinstance(value, str) and (_is_source_text(value) or value.endswith(".s")):
        if not _is_source_text(value) and not Path(value).is_file():
            raise NetsushisenError(Diagnostic("no such source file", file=value))
        program = _assemble(value, stage, symbols, cfg)
    elif isinstance(value, str) or hasattr(value, "__fspath__"):
        return load_program(arg.path(where, value), stage, symbols, cfg)
    else:
        raise arg.ArgumentError(f"{where}={arg.shown(value)}: {where} takes a nss.assemble(...) "
                                "program, an object file's or a .s source's path, or source "
                                f"text, not {type(value).__name__}")
    if stage is not None and program.proc != stage:
        raise arg.ArgumentError(f"{where}: this is a {program.proc.upper()} program, given for "
                                f"{stage!r}")
    return program


def _image(value: Any) -> MemoryImage | None:
    from netsushisen.isa.images import MemoryImage, image_from_json, load_image

    if value is None or isinstance(value, MemoryImage):
        return value
    if isinstance(value, dict):
        return image_from_json(value, "<image dict>")
    if isinstance(value, str) or hasattr(value, "__fspath__"):
        return load_image(arg.path("image", value))
    raise arg.ArgumentError(f"image={arg.shown(value)}: image takes a memory image (its file's "
                            "path, a dict as the JSON file holds, or a MemoryImage) or None, "
                            f"not {type(value).__name__}")


def run(programs: dict[str, Program | str | Path] | list[Program] | Program | str | Path,
        image: MemoryImage | dict | str | Path | None = None,
        config: MachineConfig | str | Path | None = None, engine: str | None = None,
        set: dict | list | None = None,  # noqa: A002
        max_cycles: int | None = None, defines: dict[str, int | float] | None = None) -> Results:
    """Run programs on the machine, as `netsushisen run` does. `programs`: one program (a
    `nss.assemble` result, a `.s` source's or an object file's path, or source text: it names
    its processor), a list of them, or a dict by stage (`{"ic": program or path}`); `image` a
    memory image (its file, a dict as the JSON file holds, or the object). The frame buffer, if
    the run wrote one, is `.image` (8-bit) and `extra["frame"]` (raw)."""
    from netsushisen.emulator.engine import check_engine, default_engine, make_engine
    from netsushisen.host.golden import to_u8
    from netsushisen.isa.processors import STAGES

    symbols = arg.defines("defines", defines)
    engine = arg.text("engine", engine, optional=True)
    cfg = _config(config, set, max_cycles=arg.integer("max_cycles", max_cycles, 0,
                                                      optional=True))
    if isinstance(programs, dict):
        unknown = [s for s in programs if s not in STAGES]
        if unknown:
            raise arg.ArgumentError(f"programs: no processor {arg.shown(unknown[0])} "
                                    f"(processors: {', '.join(STAGES)})")
        given = {s: _program(p, s, symbols, cfg, f"programs[{s!r}]") for s, p in programs.items()}
    else:
        items = list(programs) if isinstance(programs, (list, tuple)) else [programs]
        given = {}
        for i, p in enumerate(items):
            prog = _program(p, None, symbols, cfg, "programs" if len(items) == 1 and
                            not isinstance(programs, (list, tuple)) else f"programs[{i}]")
            if prog.proc in given:
                raise arg.ArgumentError(f"programs: two {prog.proc.upper()} programs")
            given[prog.proc] = prog
    progs = {s: given.get(s) for s in STAGES}
    img = _image(image)
    eng = make_engine(check_engine(engine) if engine else default_engine(), cfg, progs, img)
    eng.run()
    frame = np.asarray(eng.frame)
    return Results(_document(eng.statistics()), to_u8(frame) if frame.size else None,
                   np.array(eng.ids, copy=True) if frame.size else None, None,
                   {"engine": eng, "frame": frame, "programs": given})


def load_stats(path: str | Path) -> Results:
    """A statistics file (`--json`, or a `report flat` dump) as results: `.stats`, `.table()`."""
    from netsushisen.reports.tables import load_stats as read

    return Results(read(arg.path("path", path)))
