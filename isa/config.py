"""The machine configuration: every number the paper leaves open, in one place.

One dataclass tree (`MachineConfig`) holds every timing and size parameter — unit latencies,
t_r / t_c / t_g, cache and resident sizes, FIFO depths, link latency, PE count, precision, grid
and pre-pass settings. It loads from TOML, every field can be overridden on the command line as
`--set path.to.field=value`, and it is written into every statistics file so that a run can be
reproduced from its output alone. Defaults are the paper's where it fixes them (t_c = 2·t_r,
t_g = 8·t_r, direct-mapped cache with 64-byte blocks) and documented choices elsewhere.
"""

from __future__ import annotations

import copy
import dataclasses
import difflib
import re
import tomllib
import typing
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from netsushisen.isa.errors import ConfigError, Diagnostic
from netsushisen.isa.limits import field_problems, machine_problems, read_input


@dataclass
class CoreConfig:
    """Timing knobs of one stage processor (OS, IC or SC)."""

    latency: dict[str, int] = field(default_factory=dict)
    """Per-mnemonic overrides of the opcode table's default latencies (e.g. {"fdiv": 20})."""
    taken_branch_penalty: int = 1
    """Extra cycles lost when a branch or jump is taken (no delay slots, no prediction)."""
    local_words: int = 1 << 16
    """Private local memory, in words: OS keeps the voxel data here; IC/SC keep kernel tables."""


@dataclass
class MemoryConfig:
    """IC's and SC's two-level memory (the paper's memory structure; docs/timing.md §2): resident
    memory + a cache (direct-mapped as in the paper, or set-associative) in front of the shared
    global memory (ICGM for IC, SCGM for SC)."""

    t_r: int = 1
    """Resident (and local) memory access time, cycles."""
    t_c: int = 2
    """Cache hit access time, cycles (paper: 2·t_r)."""
    t_g: int = 8
    """Global memory access time on a cache miss, cycles (paper: 8·t_r)."""
    block_bytes: int = 64
    """Cache block size (paper: 64 bytes)."""
    cache_bytes: int = 8192
    """Cache capacity in bytes; ignored when `cache_share` is set and a scene gives a database."""
    cache_ways: int = 1
    """Lines per cache set: 1 (the paper's direct-mapped cache), 2, 4 or 8 (LRU replacement);
    the capacity is split into cache_bytes // (block_bytes × ways) sets."""
    resident_bytes: int = 8192
    """Resident memory capacity in bytes; ignored when `resident_share` is set."""
    cache_share: float | None = None
    """Cache size as a share of the primitive database (0..1), as in the paper's sweeps."""
    resident_share: float | None = None
    """Resident size as a share of the primitive database (0..1)."""


@dataclass
class RingConfig:
    """The CMU ring joining OS → IC → SC → OS inside a PE (the paper's CMU; docs/timing.md §3)."""

    fifo_depth: int = 64
    """Depth of every send and receive FIFO, in words."""
    link_latency: int = 1
    """Cycles for a word to cross one link between adjacent CMUs."""
    buffer_pool: bool = True
    """Structured buffer pool: separate buffer classes per message class so that no class can
    block another (the CAP-II scheme the paper cites). Off: one shared FIFO per link, which can
    deadlock under load."""
    link_buffer_words: int = 4
    """Words each link channel holds (the CMU's flit buffers, words in flight included). With the
    buffer pool on, every buffer class has its own channel of this size on every link. A channel
    streams one word per cycle only if it holds at least link_latency + 1 words."""
    deadlock_cycles: int = 10000
    """Cycles with no processor of a PE making progress, all waiting on FIFOs, before the run
    stops with a deadlock report."""


@dataclass
class GridConfig:
    """The two-level uniform space subdivision OS traverses (the paper's grid; docs/golden.md)."""

    top_resolution: int = 0
    """Voxels per axis of the top level; 0 = choose from the primitive count and OS memory."""
    sub_resolution: int = 0
    """Voxels per axis inside a subdivided top-level voxel; 0 = choose automatically."""
    subdivide_threshold: int = 8
    """A top-level voxel with more primitives than this is subdivided."""


@dataclass
class PrepassConfig:
    """The resident pre-pass (the paper's; docs/databases.md "Pre-pass"): a coarse render counts
    references per primitive."""

    share: float = 0.01
    """Share of the main pass's eye rays the pre-pass shoots (paper: about 1 %)."""


@dataclass
class RenderConfig:
    """Ray-tree rules (the SPD rendering conventions; docs/golden.md "Shading (SC) and ray spawning")."""

    max_depth: int = 5
    """Maximum ray-tree depth; the eye ray has depth 1."""
    min_weight: float = 0.0
    """Contribution cut-off: rays whose weight falls below this are not spawned (0 = none)."""
    epsilon: float = 1e-4
    """Unused since secondary rays leave from an origin offset along the normal that scales with
    the hit point and the primitive's size (docs/golden.md, "Secondary-ray origins"); kept so
    that older configuration files still load."""


@dataclass
class MachineConfig:
    pes: int = 1
    """Number of processing elements; they share ICGM and SCGM."""
    precision: str = "fp32"
    """Floating-point format of the machine: fp32 (the machine's) or fp64 (accuracy studies)."""
    distribution: str = "static"
    """How DIS hands primary rays to PEs: static (interleaved) or dynamic (load-aware)."""
    os: CoreConfig = field(default_factory=CoreConfig)
    ic: CoreConfig = field(default_factory=CoreConfig)
    sc: CoreConfig = field(default_factory=CoreConfig)
    ic_memory: MemoryConfig = field(default_factory=MemoryConfig)
    sc_memory: MemoryConfig = field(default_factory=MemoryConfig)
    ring: RingConfig = field(default_factory=RingConfig)
    grid: GridConfig = field(default_factory=GridConfig)
    prepass: PrepassConfig = field(default_factory=PrepassConfig)
    render: RenderConfig = field(default_factory=RenderConfig)
    max_cycles: int = 0
    """Stop a run after this many cycles (0 = no limit)."""

    @property
    def word_bytes(self) -> int:
        """Bytes per machine word: the FP format sets the word width (addresses count words)."""
        return 4 if self.precision == "fp32" else 8

    def validate(self, source: str = "config") -> None:
        """Reject impossible configurations with one message per problem (named after `source`)."""
        problems: list[str] = []
        if self.pes < 1:
            problems.append(f"pes must be at least 1, got {self.pes}")
        if self.precision not in ("fp32", "fp64"):
            problems.append(f"precision must be fp32 or fp64, got {self.precision!r}")
        if self.distribution not in ("static", "dynamic"):
            problems.append(f"distribution must be static or dynamic, got {self.distribution!r}")
        for name in ("ic_memory", "sc_memory"):
            mem: MemoryConfig = getattr(self, name)
            b = mem.block_bytes
            if b < self.word_bytes or b & (b - 1):
                problems.append(f"{name}.block_bytes must be a power of two of at least one word, got {b}")
            for size in ("cache_bytes", "resident_bytes"):
                if getattr(mem, size) < 0:
                    problems.append(f"{name}.{size} must not be negative")
            ways = mem.cache_ways
            if isinstance(ways, int) and 1 < ways < 8 and ways & (ways - 1):  # range: FIELD_LIMITS
                problems.append(f"{name}.cache_ways must be 1, 2, 4 or 8, got {ways}")
            elif ways in (1, 2, 4, 8) and mem.cache_bytes % max(b * ways, 1):
                whole = f"block_bytes ({b})" if ways == 1 else \
                    f"block_bytes × cache_ways ({b} × {ways}: whole sets)"
                problems.append(f"{name}.cache_bytes ({mem.cache_bytes}) must be a multiple of "
                                f"{whole}")
            for share in ("cache_share", "resident_share"):
                v = getattr(mem, share)
                if v is not None and not 0.0 <= v <= 1.0:
                    problems.append(f"{name}.{share} must lie in 0..1, got {v}")
        for name in ("os", "ic", "sc"):
            core: CoreConfig = getattr(self, name)
            if core.local_words < 0:
                problems.append(f"{name}.local_words must not be negative")
            for op, lat in core.latency.items():
                if not isinstance(lat, int):
                    problems.append(f"{name}.latency.{op} must be a whole number of cycles, got {lat!r}")
                problem = _latency_override_problem(name, op)
                if problem:
                    problems.append(problem)
        if not 0.0 < self.prepass.share <= 1.0:
            problems.append(f"prepass.share must lie in (0, 1], got {self.prepass.share}")

        problems += field_problems(self) + machine_problems(self)
        if problems:
            raise ConfigError([Diagnostic(p, file=source) for p in problems])

    def to_dict(self) -> dict[str, Any]:
        return dataclasses.asdict(self)

    @classmethod
    def load(cls, path: str | Path | None = None,
             overrides: dict[str, Any] | list[str] | None = None) -> MachineConfig:
        """Defaults, then the TOML file `path`, then `overrides` (`{"ic.latency.fmul": 6}` or
        `["ic.latency.fmul=6"]`, as `--set` takes them); validated (`load_config`)."""
        return load_config(path, override_items(overrides))

    def with_(self, overrides: dict[str, Any] | list[str] | None = None,
              **fields: Any) -> MachineConfig:
        """A copy with `overrides` (`{"ic.latency.fmul": 6}`, set paths as `--set` takes them)
        and top-level `fields` (`pes=4`) applied; validated. This configuration is unchanged."""
        config = copy.deepcopy(self)
        problems: list[Diagnostic] = []
        for item in override_items(overrides) + override_items(fields):
            try:
                apply_override(config, item)
            except ConfigError as err:
                problems += err.diagnostics
        if problems:
            raise ConfigError(problems)
        config.validate()
        return config


def override_items(overrides: dict[str, Any] | list[str] | None) -> list[str]:
    """Overrides as `--set` items: `path=value`, a value written as TOML writes it."""
    if overrides is None:
        return []
    if isinstance(overrides, dict):
        return [f"{k}={_scalar(v)}" for k, v in overrides.items()]
    return list(overrides)


def _latency_override_problem(proc: str, mnemonic: str) -> str | None:
    """Why `<proc>.latency.<mnemonic>` cannot be overridden (None when it can).

    Load access times of IC and SC come from their memory configuration (ld and ldr: t_r; ldg:
    t_c on a hit, t_g on a miss), so a latency override there would be a second, conflicting
    source of truth. OS's local `ld` has no memory configuration: its access time is the `ld`
    latency (table default, overridable as os.latency.ld).
    """
    from netsushisen.isa.opcodes import OPCODES  # late: opcodes imports nothing from here

    op = OPCODES.get(mnemonic)
    if op is None:
        known = [m for m, o in OPCODES.items() if proc in o.procs]
        return (f"{proc}.latency.{mnemonic}: unknown mnemonic {mnemonic!r}"
                + _did_you_mean(mnemonic, known, list_known=False))
    if proc not in op.procs:
        return f"{proc}.latency.{mnemonic}: {proc.upper()} has no {mnemonic!r} instruction"
    if op.kind == "load" and proc in ("ic", "sc"):
        return (f"{proc}.latency.{mnemonic}: {proc.upper()} load times come from {proc}_memory "
                "(t_r for ld/ldr, t_c/t_g for ldg)")
    return None


# ---------------------------------------------------------------------------------------------
# Loading, overriding, dumping


def _convert(value: Any, tp: Any, path: str, strict: bool = False) -> Any:
    """Coerce a TOML or command-line value to the field's declared type, or explain why not.
    `strict` (a value from a TOML file, which has its own types): a string is never a bool or
    a number (`buffer_pool = "no"` is an error); on the command line (`--set`) the text is all
    there is, so `no`, `0x10` and `1e3` are read as the field's type."""
    origin = typing.get_origin(tp)
    args = typing.get_args(tp)
    if origin is typing.Union or str(origin) == "<class 'types.UnionType'>":
        if value is None or (not strict and isinstance(value, str) and value.lower() in ("none", "")):
            if type(None) in args:
                return None
        inner = [a for a in args if a is not type(None)]
        return _convert(value, inner[0], path, strict)
    if tp is bool:
        if isinstance(value, bool):
            return value
        if not strict and isinstance(value, str) and value.lower() in ("true", "1", "yes", "on"):
            return True
        if not strict and isinstance(value, str) and value.lower() in ("false", "0", "no", "off"):
            return False
        raise ConfigError(f"{path}: expected true or false, got {_shown(value)}")
    if tp is int:
        if isinstance(value, int) and not isinstance(value, bool):
            return value
        if isinstance(value, str) and not strict:
            try:
                return int(value, 0)
            except ValueError:
                pass
        raise ConfigError(f"{path}: expected a whole number, got {_shown(value)}")
    if tp is float:
        if isinstance(value, (int, float)) and not isinstance(value, bool):
            return float(value)
        if isinstance(value, str) and not strict:
            try:
                return float(value)
            except ValueError:
                pass
        raise ConfigError(f"{path}: expected a number, got {_shown(value)}")
    if tp is str:
        if strict and not isinstance(value, str):
            raise ConfigError(f"{path}: expected a string, got {_shown(value)}")
        return str(value)
    if origin is dict:
        if not isinstance(value, dict):
            raise ConfigError(f"{path}: expected a table, got {_shown(value)}")
        return {str(k): _convert(v, args[1], f"{path}.{k}", strict) for k, v in value.items()}
    raise ConfigError(f"{path}: unsupported type {tp}")


def _shown(value: Any) -> str:
    """A value as the user wrote it, with what TOML made of it (`"no"` (a string))."""
    kinds = {bool: "a boolean", int: "a whole number", float: "a number", str: "a string",
             dict: "a table", list: "an array"}
    kind = kinds.get(type(value))
    text = _scalar(value) if isinstance(value, (bool, int, float, str)) else repr(value)
    return f"{text} ({kind})" if kind else text


def _did_you_mean(name: str, known: list[str], list_known: bool = True) -> str:
    """`; did you mean 'x'?` for the closest known name, else the list of known names (or
    nothing, with list_known=False: the opcode table is too long to list)."""
    close = difflib.get_close_matches(name, known, n=1, cutoff=0.6)
    if close:
        return f"; did you mean {close[0]!r}?"
    return "; known: " + ", ".join(sorted(known)) if list_known else ""


def _apply(obj: Any, data: dict[str, Any], prefix: str, problems: list[tuple[str, str]],
           strict: bool = False) -> None:
    """Set `data`'s fields on `obj`; every problem (unknown field or section, wrong type) is
    appended to `problems` as (field path, message) and the other fields still apply, so a
    file's every error is reported at once."""
    hints = typing.get_type_hints(type(obj))
    names = [f.name for f in dataclasses.fields(obj)]
    for key, value in data.items():
        path = f"{prefix}{key}"
        if key not in names:
            what = "section" if isinstance(value, dict) and strict else "field"
            problems.append((path, f"unknown configuration {what} {path!r}"
                                   + _did_you_mean(path, [f"{prefix}{n}" for n in names])))
            continue
        current = getattr(obj, key)
        if dataclasses.is_dataclass(current):
            if not isinstance(value, dict):
                problems.append((path, f"{path}: expected a table of fields, got {_shown(value)}"))
                continue
            _apply(current, value, path + ".", problems, strict)
            continue
        try:
            setattr(obj, key, _convert(value, hints[key], path, strict))
        except ConfigError as err:
            problems.append((path, err.diagnostics[0].message))


def key_lines(text: str) -> dict[str, int]:
    """The 1-based line of every `[table]` header and `key = value` line, by dotted path.

    tomllib gives the values but no positions. The configuration files this project reads and
    writes are flat — `[section]` headers and `key = value` lines, as `config --dump` writes
    them — so a scan of the text is enough: a header sets the current table, a `key =` line
    (bare or quoted key, dotted allowed) names `table.key`. A key inside an inline table or a
    multi-line value is not found; `line_of` then falls back to its table's line."""
    lines: dict[str, int] = {}
    table = ""
    for n, raw in enumerate(text.splitlines(), 1):
        s = raw.strip()
        if not s or s.startswith("#"):
            continue
        header = re.match(r"^\[\s*([^\[\]]+?)\s*\]", s)
        if header and not s.startswith("[["):
            table = _dotted(header.group(1))
            lines.setdefault(table, n)
            continue
        key = re.match(r"""^((?:"[^"]*"|'[^']*'|[A-Za-z0-9_\-]+)(?:\s*\.\s*(?:"[^"]*"|'[^']*'|[A-Za-z0-9_\-]+))*)\s*=""", s)
        if key:
            dotted = _dotted(key.group(1))
            lines.setdefault(f"{table}.{dotted}" if table else dotted, n)
    return lines


def _dotted(key: str) -> str:
    return ".".join(part.strip().strip("\"'") for part in key.split("."))


def line_of(lines: dict[str, int], path: str) -> int | None:
    """The line of field `path`, else of its nearest enclosing table that has one."""
    parts = path.split(".")
    for k in range(len(parts), 0, -1):
        found = lines.get(".".join(parts[:k]))
        if found is not None:
            return found
    return None


def load_config(path: str | Path | None = None, overrides: list[str] | None = None) -> MachineConfig:
    """Defaults, then a TOML file, then `field.path=value` overrides; validated. Every problem
    is reported at once, a file's as `file:line: error: ...` (`key_lines`)."""
    config = MachineConfig()
    source = str(path) if path is not None else "config"
    located: list[tuple[str, str]] = []  # (field path, message), of the file
    lines: dict[str, int] = {}
    if path is not None:
        p = Path(path)
        try:
            text = read_input(p, "configuration file").decode("utf-8")
            data = tomllib.loads(text)
        except (FileNotFoundError, IsADirectoryError):
            raise ConfigError(Diagnostic("no such configuration file", file=source)) from None
        except UnicodeDecodeError:
            raise ConfigError(Diagnostic("not valid TOML: not UTF-8 text", file=source)) from None
        except RecursionError:
            raise ConfigError(Diagnostic("not valid TOML: nested too deeply", file=source)) from None
        except tomllib.TOMLDecodeError as err:
            where = re.search(r"\(at line (\d+), column (\d+)\)", str(err))
            message = re.sub(r"\s*\(at line \d+, column \d+\)", "", str(err))
            raise ConfigError(Diagnostic(f"not valid TOML: {message}", file=source,
                                         line=int(where[1]) if where else None,
                                         col=int(where[2]) if where else None)) from None
        lines = key_lines(text)
        _apply(config, data, "", located, strict=True)
    diagnostics = [Diagnostic(message, file=source, line=line_of(lines, field_path))
                   for field_path, message in located]
    overridden = set()
    for item in overrides or []:
        overridden.add(item.partition("=")[0].strip())
        try:
            apply_override(config, item)
        except ConfigError as err:
            diagnostics += err.diagnostics
    try:
        config.validate(source)
    except ConfigError as err:
        for d in err.diagnostics:  # each problem starts with its field's path
            field_path = d.message.split(" ", 1)[0].rstrip(":")
            if field_path in overridden and path is not None:  # the value is --set's, not the file's
                diagnostics.append(dataclasses.replace(d, file=None))
            else:
                diagnostics.append(dataclasses.replace(d, line=line_of(lines, field_path)))
    if diagnostics:
        diagnostics.sort(key=lambda d: (d.file != source, d.line is None, d.line or 0))
        raise ConfigError(diagnostics)
    return config


def config_from_dict(data: dict[str, Any], source: str = "config") -> MachineConfig:
    """The configuration a statistics file records (`MachineConfig.to_dict`), read back so a
    report can reason with the machine the run had; every problem at once, named after `source`."""
    config = MachineConfig()
    problems: list[tuple[str, str]] = []
    _apply(config, data, "", problems)
    if problems:
        raise ConfigError([Diagnostic(message, file=source) for _, message in problems])
    config.validate(source)
    return config


def apply_override(config: MachineConfig, item: str) -> None:
    """Apply one `--set path.to.field=value` (dict fields take `ic.latency.fdiv=20`)."""
    if "=" not in item:
        raise ConfigError(f"--set {item!r}: expected path.to.field=value")
    path, _, raw = item.partition("=")
    parts = path.strip().split(".")
    obj: Any = config
    for i, part in enumerate(parts[:-1]):
        if isinstance(obj, dict):
            raise ConfigError(f"--set {item!r}: {'.'.join(parts[:i + 1])} is not a table")
        names = [f.name for f in dataclasses.fields(obj)] if dataclasses.is_dataclass(obj) else []
        if part not in names:
            here = ".".join(parts[:i + 1])
            raise ConfigError(f"--set {item!r}: unknown configuration field {here!r}"
                              + _did_you_mean(here, [".".join([*parts[:i], n]) for n in names]))
        nxt = getattr(obj, part)
        if isinstance(nxt, dict):  # e.g. ic.latency.fdiv=20
            if i != len(parts) - 2:
                raise ConfigError(f"--set {item!r}: too many parts after {part!r}")
            nxt[parts[-1]] = _convert(raw, int, path)
            return
        if not dataclasses.is_dataclass(nxt):  # e.g. precision.foo=1: precision is a value
            raise ConfigError(f"--set {item!r}: {'.'.join(parts[:i + 1])} is a value, not a "
                              "table: it has no fields")
        obj = nxt
    data: Any = raw
    try:  # accept TOML literals (true, 0.3, "x"); fall back to the raw string
        data = tomllib.loads(f"v = {raw}")["v"]
    except tomllib.TOMLDecodeError:
        pass
    problems: list[tuple[str, str]] = []
    _apply(obj, {parts[-1]: data}, ".".join(parts[:-1]) + "." if len(parts) > 1 else "", problems)
    if problems:
        raise ConfigError(problems[0][1])


def _scalar(v: Any) -> str:
    """A scalar as TOML writes it."""
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, str):
        return '"' + v.replace("\\", "\\\\").replace('"', '\\"') + '"'
    return repr(v)


def dump_toml(config: MachineConfig,
              describe: typing.Callable[[str, Any], str | None] | None = None) -> str:
    """The configuration as TOML that `load_config` reads back to an equal config. With
    `describe(path, value)` (`config --dump`: reports/descriptions.py), each field is preceded
    by a `# description (unit; default ...)` comment, and each processor's latency table also
    lists, commented out, every latency it can override at its default (the opcode table's)."""
    from netsushisen.isa.opcodes import OPCODES  # late: opcodes imports nothing from here

    lines: list[str] = []

    def note(path: str, value: Any) -> None:
        text = describe(path, value) if describe else None
        if text:
            lines.append(f"# {text}")

    def emit(obj: Any, table: str) -> None:
        subtables = []
        doc_lines: list[tuple[str, Any, str]] = []
        for f in dataclasses.fields(obj):
            v = getattr(obj, f.name)
            if dataclasses.is_dataclass(v) or isinstance(v, dict):
                subtables.append((f.name, v))
            else:
                text = f"# {f.name} = (unset)" if v is None else f"{f.name} = {_scalar(v)}"
                doc_lines.append((f.name, v, text))
        if doc_lines:
            if table:
                lines.append(f"\n[{table}]")
            for name, v, text in doc_lines:
                note(f"{table}.{name}" if table else name, v)
                lines.append(text)
        for name, v in subtables:
            full = f"{table}.{name}" if table else name
            if isinstance(v, dict):
                lines.append(f"\n[{full}]")
                for k, x in sorted(v.items()):
                    text = describe(f"{full}.{k}", x) if describe else None
                    lines.append(f"{k} = {_scalar(x)}".ljust(20) + f"# {text}" if text
                                 else f"{k} = {_scalar(x)}")
                if describe and name == "latency":
                    for m, op in OPCODES.items():
                        if m not in v and _latency_override_problem(table, m) is None:
                            lines.append(f"# {m} = {op.latency}".ljust(20)
                                         + f"# {describe(f'{full}.{m}', op.latency)}")
            else:
                emit(v, full)

    emit(config, "")
    return "\n".join(lines).lstrip("\n") + "\n"
