"""The hostile-input corpus (issue 30, item 2): every input category a user can hand the tools,
each case a command line and the files it reads.

The corpus is generated from a fixed seed (the same cases on every machine and every run) by
mutating small valid inputs with values that have broken the tools before (negative, zero, NaN,
infinite, huge and wrongly typed values; deep nesting; truncation; bytes that are not text), and
adds the reliability review's regressions by hand (`REGRESSIONS`). `python tests/fuzz/run.py`
runs it; tests/test_fuzz.py runs a sample by default and all of it under `-m slow`.
"""

from __future__ import annotations

import json
import random
from dataclasses import dataclass, field

SEED = 30

CATEGORIES = ("config", "set", "nff", "asm", "object", "stats", "spec", "scheduler", "files")


@dataclass(frozen=True)
class Case:
    """One run: `argv` after `netsushisen`, in a fresh folder holding `files`."""

    category: str
    name: str
    argv: tuple[str, ...]
    files: dict[str, bytes] = field(default_factory=dict, hash=False)


HOSTILE = ["-1", "0", "-0.0", "1e308", "-1e308", "nan", "inf", "-inf", "2147483648",
           "99999999999999999999999", "1e9", "0.5", "true", '"x"', '""', "[1, 2]", "{a = 1}",
           "[[[[[[]]]]]]", '"' + "A" * 5000 + '"', "0x7fffffff", "-2147483649", "1_000_000"]
"""TOML values that are wrong for some field: types, signs, sizes, non-finite numbers."""

SET_VALUES = ["-1", "0", "nan", "inf", "-inf", "1e9", "1000000000", "x", "", "true", "none",
              "2147483648", "0x10", "1e-320", "64", "8", "0.5", "[1]", "'", "=", "\x01"]

FIELDS = ["pes", "precision", "distribution", "max_cycles", "os.local_words", "ic.local_words",
          "os.taken_branch_penalty", "ic.latency.fmul", "ic.latency.fdiv", "sc.latency.nope",
          "os.latency.add", "ic_memory.t_r", "ic_memory.t_c", "ic_memory.t_g",
          "ic_memory.block_bytes", "ic_memory.cache_bytes", "ic_memory.resident_bytes",
          "ic_memory.cache_share", "sc_memory.resident_share", "ring.fifo_depth",
          "ring.link_latency", "ring.link_buffer_words", "ring.deadlock_cycles",
          "ring.buffer_pool", "grid.top_resolution", "grid.sub_resolution",
          "grid.subdivide_threshold", "prepass.share", "render.max_depth", "render.min_weight",
          "render.epsilon", "nosuch.field", "ic", "ic.latency", "ring..fifo_depth"]

NFF = b"""v
from 0 0 -10
at 0 0 0
up 0 1 0
angle 40
hither 1
resolution 8 8
b 0.1 0.1 0.1
l 5 5 -5
f 1 0 0 0.6 0.3 20 0.2 1
s 0 0 0 1
p 3
-1 -1 2
1 -1 2
0 1 2
c 0 -1 0 0.5 0 1 0 0.5
"""

NFF_NUMBERS = ["nan", "inf", "-inf", "1e308", "-1e308", "0", "-0", "1e-320", "3e38",
               "1000000000", "-5", "x", "1e", "0x10", "1.5.5"]

ASM = """.proc os
.equ N, 4
.macro twice x
    addi r1, r1, \\x
    addi r1, r1, \\x
.endm
start:
    addi r1, r0, N
    twice 2
.rept 3
    addi r2, r2, 1
.endr
    bnez r0, start
    halt
.data
table: .word 1, 2, 3
"""

ASM_TOKENS = [".rept 70000", ".rept -1", ".rept 1e9", ".endr", ".endm", ".macro", ".macro m x",
              "\\x", "\\@", "r64", "r-1", "r999", "[r1 +", "[r1 + r2]", "1 << 9999", "1/0",
              "(" * 300 + "1" + ")" * 300, "+".join(["1"] * 400), ".equ N, N", ".equ Q, 1e999",
              '.include "/dev/zero"', '.include "prog.s"', '.include "../../../../etc/passwd"',
              ".if", ".else", ".endif", ".proc sc", ".proc xx", "{ addi r1, r0, 1",
              "\x00", "\u00e9", "start:", "j nowhere", "addi r1, r0, 2147483648",
              "ld r1, [r0 + 4294967296]", ".word 1e99", ".float nan", ".space -5",
              ".space 99999999999", "A" * 70000]

ASM_MACRO_BOMB = (".proc os\n" + ".macro m0\n nop\n.endm\n" +
                  "".join(f".macro m{k}\n m{k - 1}\n m{k - 1}\n.endm\n" for k in range(1, 41)) +
                  " m40\n halt\n")

OBJ_VALUES = [2 ** 70, -(2 ** 70), -1, 999, 64, 1e308, "x", None, [], {}, [1], True,
              "a\n.include x", 2 ** 31, -(2 ** 31) - 1]

SPEC = """scenes = ["tetra"]
res = 4
[vary]
"ic_memory.cache_bytes" = [1024, 4096]
"""

SPEC_LINES = ['"max_cycles" = [-5]', '"ic_memory.t_g" = {start = 1, stop = 1e15, step = 1}',
              '"ic_memory.t_g" = {start = 1, stop = 0, step = 1}',
              '"ic_memory.t_g" = {start = 1, stop = 10, step = 0}',
              '"ic_memory.t_g" = {start = nan, stop = 10, step = 1}',
              '"ic_memory.t_g" = []', 'x = [[1, 2]]', '"nosuch" = [1]', 'res = -1', 'res = 1e9',
              'scenes = []', 'scenes = ["/dev/zero"]', 'scenes = ["nosuch.nff"]',
              '[derive]\n"ic_memory.t_c" = "x ** 99999999999"',
              '[derive]\n"ic_memory.t_c" = "__import__(\'os\')"',
              '[derive]\n"ic_memory.t_c" = "1/0"', '[zip]\na = [1]\nb = [1, 2]',
              "\n".join(f'"ring.fifo_depth{i}" = [1,2,3,4,5,6,7,8,9,10]' for i in range(9)),
              'engine = "nosuch"', 'config = "/dev/zero"', 'set = ["ring.fifo_depth=-1"]']

SCHEDULERS = ["garbage", "", "tcp://", "tcp://127.0.0.1", "tcp://127.0.0.1:0",
              "tcp://127.0.0.1:99999", "tcp://127.0.0.1:9", "http://127.0.0.1:80", "::::",
              "tcp://[::1", "tcp://[::1]:9", "tls://127.0.0.1:9", "inproc://x", "ws://x:1",
              "tcp://" + "a" * 300 + ":9", "tcp://\u00e9:9", "tcp://127.0.0.1:-1", "-",
              "tcp://127.0.0.1:9/extra", "ucx://127.0.0.1:9"]

FILES = [("render", "/dev/zero"), ("golden", "/dev/null"), ("asm", "/dev/zero"),
         ("disasm", "/dev/zero"), ("config", "--check", "/dev/zero"), ("sweep", "/dev/null"),
         ("report", "ilp", "/dev/zero"), ("render", "."), ("disasm", "."), ("asm", "."),
         ("config", "--check", "."), ("report", "ilp", "."), ("sweep", "."),
         ("run", "--os", "/dev/zero")]

REGRESSIONS = [
    Case("asm", "macro-bomb", ("asm", "prog.s", "--proc", "os", "--stats"),
         {"prog.s": ASM_MACRO_BOMB.encode()}),
    Case("asm", "rept-nest", ("asm", "prog.s", "--proc", "os", "--stats"),
         {"prog.s": b".proc os\n" + b".rept 65536\n" * 5 + b" nop\n" + b".endr\n" * 5 + b" halt\n"}),
    Case("asm", "equ-200k", ("asm", "prog.s", "--proc", "os", "--stats"),
         {"prog.s": (".proc os\n.equ z, " + "+".join(["1"] * 200000) + "\n halt\n").encode()}),
    Case("config", "deep-toml", ("config", "--check", "cfg.toml"),
         {"cfg.toml": b"a = " + b"[" * 100000 + b"]" * 100000 + b"\n"}),
    Case("set", "top-resolution", ("config", "--set", "grid.top_resolution=100000")),
    Case("set", "t-g", ("config", "--set", "ic_memory.t_g=2000000000")),
    Case("set", "max-depth", ("config", "--set", "render.max_depth=100000000")),
    Case("set", "epsilon-nan", ("config", "--set", "render.epsilon=nan")),
    Case("nff", "many-spheres", ("golden", "scene.nff", "--res", "2"),
         {"scene.nff": NFF + b"s 0 0 0 1\n" * 300000}),
    Case("nff", "coincident", ("golden", "scene.nff", "--res", "2"),
         {"scene.nff": NFF + b"s 0 0 0 1\n" * 20000}),
    Case("object", "2**70", ("disasm", "prog.o"), {}),  # files filled in by _objects()
]


def _toml_cases(rng: random.Random, n: int) -> list[Case]:
    out = []
    for i in range(n):
        lines = []
        for _ in range(rng.randint(1, 4)):
            path = rng.choice(FIELDS).split(".")
            value = rng.choice(HOSTILE)
            if len(path) == 1:
                lines.append(f"{path[0]} = {value}")
            else:
                lines.append(f"[{'.'.join(path[:-1])}]\n{path[-1]} = {value}")
        text = "\n".join(lines) + "\n"
        if i % 7 == 3:
            text = text[: rng.randint(0, len(text))]  # truncated
        if i % 11 == 5:
            text = text.replace("=", "==", 1)
        out.append(Case("config", f"config-{i}", ("config", "--check", "cfg.toml"),
                        {"cfg.toml": text.encode()}))
    out.append(Case("config", "binary", ("config", "--check", "cfg.toml"),
                    {"cfg.toml": bytes(range(256))}))
    return out


def _set_cases(rng: random.Random, n: int) -> list[Case]:
    out = []
    for i in range(n):
        field_ = rng.choice(FIELDS)
        value = rng.choice(SET_VALUES)
        out.append(Case("set", f"set-{i}", ("config", "--set", f"{field_}={value}")))
    out.append(Case("set", "no-equals", ("config", "--set", "pes")))
    out.append(Case("set", "render", ("render", "tetra", "--res", "2", "--set", "pes=-3")))
    return out


def _nff_cases(rng: random.Random, n: int) -> list[Case]:
    out = []
    words = NFF.decode().split("\n")
    for i in range(n):
        lines = list(words)
        for _ in range(rng.randint(1, 3)):
            k = rng.randrange(len(lines))
            tokens = lines[k].split()
            how = rng.randrange(5)
            if how == 0 and tokens:
                tokens[rng.randrange(len(tokens))] = rng.choice(NFF_NUMBERS)
            elif how == 1:
                del lines[k]
                continue
            elif how == 2:
                lines.insert(k, lines[k])
            elif how == 3 and tokens:
                tokens = tokens[: rng.randrange(len(tokens) + 1)]
            else:
                tokens = ["p", rng.choice(["0", "1", "-2", "1000000000", "nan"])]
            lines[k] = " ".join(tokens)
        out.append(Case("nff", f"nff-{i}", ("golden", "scene.nff", "--res", "2"),
                        {"scene.nff": "\n".join(lines).encode()}))
    out.append(Case("nff", "binary", ("golden", "scene.nff"), {"scene.nff": bytes(range(256))}))
    out.append(Case("nff", "empty", ("golden", "scene.nff"), {"scene.nff": b""}))
    return out


def _asm_cases(rng: random.Random, n: int) -> list[Case]:
    out = []
    base = ASM.split("\n")
    for i in range(n):
        lines = list(base)
        for _ in range(rng.randint(1, 3)):
            k = rng.randrange(len(lines))
            token = rng.choice(ASM_TOKENS)
            if rng.random() < 0.5:
                lines.insert(k, token)
            else:
                lines[k] = lines[k] + " " + token
        out.append(Case("asm", f"asm-{i}", ("asm", "prog.s", "--proc", "os", "-o", "prog.o"),
                        {"prog.s": "\n".join(lines).encode("utf-8", "surrogateescape")}))
    out.append(Case("asm", "define", ("asm", "prog.s", "-D", "N=" + "+".join(["1"] * 5000)),
                    {"prog.s": ASM.encode()}))
    return out


def _base_object() -> dict:
    from netsushisen.asm.assembler import assemble_text

    return assemble_text(ASM).to_json()


def _object_cases(rng: random.Random, n: int) -> list[Case]:
    base = _base_object()
    out = []
    for i in range(n):
        obj = json.loads(json.dumps(base))
        how = rng.randrange(5)
        value = rng.choice(OBJ_VALUES)
        if how == 0:  # an operand
            b = rng.randrange(len(obj["bundles"]))
            op = obj["bundles"][b][0]
            if len(op) > 1:
                op[rng.randrange(1, len(op))] = value
        elif how == 1:
            obj["labels"][str(value) if not isinstance(value, str) else value] = ["text", 0]
        elif how == 2:
            obj["data"].append(["i", value])
        elif how == 3:
            obj[rng.choice(["proc", "version", "bundles", "labels", "data", "defines"])] = value
        else:
            obj["bundles"][0] = [[rng.choice(["addi", "fdiv", "send", "ldg", "nosuch", "halt"]),
                                  value, value, value]]
        text = json.dumps(obj).encode()
        argv = ("disasm", "prog.o") if i % 2 else ("run", "--os", "prog.o", "--engine",
                                                   "reference", "--max-cycles", "200")
        out.append(Case("object", f"object-{i}", argv, {"prog.o": text}))
    return out


def base_stats(folder) -> dict:
    """A valid statistics file: the base program run on the reference engine."""
    from pathlib import Path

    from netsushisen.cli import main

    folder = Path(folder)
    (folder / "base.o").write_text(json.dumps(_base_object()))
    assert main(["run", "--os", str(folder / "base.o"), "--engine", "reference", "-q",
                 "--json", str(folder / "base.json")]) == 0
    return json.loads((folder / "base.json").read_text())


def _stats_cases(rng: random.Random, n: int, base: dict) -> list[Case]:
    out = []
    for i in range(n):
        data = json.loads(json.dumps(base))
        keys = []

        def walk(d, path):
            if isinstance(d, dict):
                for k, v in d.items():
                    keys.append(path + [k])
                    walk(v, path + [k])
        walk(data, [])
        path = rng.choice(keys)
        parent = data
        for k in path[:-1]:
            parent = parent[k]
        how = rng.randrange(3)
        if how == 0:
            del parent[path[-1]]
        else:
            parent[path[-1]] = rng.choice([-1, None, "x", [], {}, 1e308, 2 ** 70, True])
        report = rng.choice(["ilp", "stalls", "memory", "annotate", "flat"])
        out.append(Case("stats", f"stats-{i}", ("report", report, "stats.json"),
                        {"stats.json": json.dumps(data).encode()}))
    out.append(Case("stats", "deep", ("report", "ilp", "stats.json"),
                    {"stats.json": b'{"a": ' + b"[" * 100000 + b"]" * 100000 + b"}"}))
    return out


def _spec_cases(rng: random.Random, n: int) -> list[Case]:
    out = []
    for i in range(n):
        extra = "\n".join(rng.sample(SPEC_LINES, rng.randint(1, 2)))
        text = SPEC + extra + "\n" if not extra.startswith(("res", "scenes", "engine", "config", "set")) \
            else extra + "\n" + SPEC
        out.append(Case("spec", f"spec-{i}", ("sweep", "spec.toml", "-o", "out", "--engine",
                                              "reference", "--scheduler", "tcp://127.0.0.1:9"),
                        {"spec.toml": text.encode()}))
    return out


def _scheduler_cases() -> list[Case]:
    return [Case("scheduler", f"scheduler-{i}", ("sweep", "spec.toml", "-o", "out", "--engine",
                                                  "reference", "--scheduler", address),
                 {"spec.toml": SPEC.encode()}) for i, address in enumerate(SCHEDULERS)]


def _file_cases() -> list[Case]:
    return [Case("files", f"files-{i}", argv) for i, argv in enumerate(FILES)]


def cases(per_category: int = 40, stats_base: dict | None = None) -> list[Case]:
    """The whole corpus (`per_category` generated cases a category, plus the fixed ones);
    `stats_base` is a valid statistics file to mutate (tests/fuzz/run.py makes one)."""
    rng = random.Random(SEED)
    out = (_toml_cases(rng, per_category) + _set_cases(rng, per_category)
           + _nff_cases(rng, per_category) + _asm_cases(rng, per_category)
           + _object_cases(rng, per_category))
    if stats_base is not None:
        out += _stats_cases(rng, per_category, stats_base)
    out += _spec_cases(rng, per_category // 2) + _scheduler_cases() + _file_cases()
    obj = _base_object()
    obj["bundles"][0][0][3] = 2 ** 70
    regressions = [c if c.name != "2**70" else Case(c.category, c.name, c.argv,
                                                   {"prog.o": json.dumps(obj).encode()})
                   for c in REGRESSIONS]
    return out + regressions
