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

CATEGORIES = ("config", "set", "nff", "asm", "object", "stats", "spec", "scheduler", "files",
              "linear", "numbers", "api", "cache")


@dataclass(frozen=True)
class Case:
    """One run: `argv` after `netsushisen`, in a fresh folder holding `files`."""

    category: str
    name: str
    argv: tuple[str, ...]
    files: dict[str, bytes] = field(default_factory=dict, hash=False)
    python: str = ""
    """Python code run instead of the command line (the API and cache cases): `nss` is the
    package; a NetsushisenError is its one error line and exit 1 (API_HARNESS)."""


API_HARNESS = """import sys
import netsushisen as nss
try:
    exec(compile(sys.argv[1], "<case>", "exec"), {"nss": nss})
except nss.NetsushisenError as err:
    print(err, file=sys.stderr)
    sys.exit(1)
"""
"""How a `python` case runs: only the API's own errors are expected; anything else is a
traceback, which breaks the rule."""


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


LINEAR_OPS = ["ld r{a}, [r{b} + {k}]", "st r{a}, [r{b} + {k}]", "addi r{a}, r{b}, {k}",
              "fadd r{a}, r{b}, r{a}", "fmul r{a}, r{a}, r{b}", "beq r{a}, r0, out",
              "ldr r{a}, [r{b} + {k}]", "li r{a}, {k}"]


def _linear_cases(rng: random.Random, n: int) -> list[Case]:
    """Linear assembly (issue 46, Why 1-2): `.sched` regions, `.pipeline` loops and `.deadout`
    superblocks of random operations and sizes up to past every limit, with latencies up to
    the configuration's."""
    out = []
    for i in range(n):
        size = rng.choice([1, 10, 200, 2047, 2049, 5000])
        ops = [rng.choice(LINEAR_OPS).format(a=rng.randint(1, 30), b=rng.randint(0, 30),
                                             k=rng.randint(0, 99)) for _ in range(size)]
        head = rng.choice([[".sched"], [".sched inorder"], [".sched", ".deadout r31"],
                           [".sched", ".temps r40-r47", ".pipeline"]])
        label = ["loop:"] if head[-1] == ".pipeline" else []
        tail = ["        blt r1, r2, loop"] if label else []
        body = [".proc ic", *head] + [f"{label[0] if label and k == 0 else ''}        {op}"
                                      for k, op in enumerate(ops)] + tail
        text = "\n".join(body + ["        halt", ".endsched", "out:    halt"]) + "\n"
        argv = ["asm", "k.s", "-o", "k.o"]
        if rng.random() < 0.4:
            argv += ["--set", f"ic_memory.t_r={rng.choice([1, 64, 1024, 4096])}"]
        if rng.random() < 0.3:
            argv += ["--bounds", "--optimum-ops", str(rng.choice([0, 40, 100000]))]
        out.append(Case("linear", f"linear-{i}", tuple(argv), {"k.s": text.encode()}))
    out.append(Case("linear", "dot-t_r-4096", ("asm", "dot.s", "--set", "ic_memory.t_r=4096",
                                               "-o", "d.o"), {"dot.s": _dot_source()}))
    return out


def _dot_source() -> bytes:
    from pathlib import Path

    return (Path(__file__).resolve().parents[2] / "kernels" / "examples" / "dot_ic.s").read_bytes()


NUMBERS = ["1" + "0" * 100_000, "-" + "9" * 5000, "1e999999", "NaN", "Infinity", "-Infinity",
           str(10 ** 400), str(1 << 64), str(-(1 << 63) - 1)]


def _number_cases(rng: random.Random, base: dict) -> list[Case]:
    """Statistics and object files with numbers no count can be (issue 46, Why 3), for every
    reader: each report, disasm, run; and a flat dump whose names are not a tree."""
    out = []
    reports = ["flat", "ilp", "stalls", "annotate", "memory", "diff", "bounds"]
    for i, raw in enumerate(NUMBERS):
        data = json.loads(json.dumps(base))
        data["processors"]["pe0.os"]["stalls"]["branch"] = "@@"
        text = json.dumps(data).replace('"@@"', raw).encode()
        report = reports[i % len(reports)]
        argv = ("report", report, "good.json", "stats.json") if report == "diff" else \
            ("report", report, "stats.json")
        out.append(Case("numbers", f"numbers-stats-{i}", argv,
                        {"stats.json": text, "good.json": json.dumps(base).encode()}))
        obj = _base_object()
        obj["bundles"][0][0][1] = "@@"
        blob = json.dumps(obj).replace('"@@"', raw).encode()
        argv = ("disasm", "prog.o") if i % 2 else ("run", "--os", "prog.o", "--engine", "reference")
        out.append(Case("numbers", f"numbers-object-{i}", argv, {"prog.o": blob}))
    for i, flat in enumerate(["processors 5\nprocessors.pe0.ic.cycles.sub 3\n",
                              "processors.pe0.ic.cycles.sub 3\nprocessors 5\n",
                              "pe0.ic.cycles 1e999999\n", "pe0.ic.cycles " + "7" * 9000 + "\n",
                              "dis.messages_per_pe.x 1\n"]):
        out.append(Case("numbers", f"numbers-flat-{i}", ("report", "ilp", "stats.txt"),
                        {"stats.txt": flat.encode()}))
    return out


API_CALLS = ['nss.render("tetra", res="64")', 'nss.render("tetra", res=2.5)',
             'nss.render("tetra", res=True)', 'nss.render("tetra", res=None)',
             'nss.golden("tetra", res="8")', "nss.render(None)", "nss.render(42)",
             'nss.render("tetra", res=2, set=[1, 2])', 'nss.render("tetra", res=2, config=123)',
             "nss.assemble(None)", 'nss.assemble(b".proc ic\\n halt\\n")',
             'nss.assemble(".proc ic\\n halt\\n", defines=["N"])', 'nss.run({"ic": 5})',
             'nss.load_stats("stats.txt")', "nss.scene(5)", "nss.run(5)",
             'nss.run(".proc ic\\n halt\\n", image=5, engine="reference")',
             'r = nss.run(".proc ic\\n halt\\n", engine="reference"); r.table(None)',
             'r = nss.run(".proc ic\\n halt\\n", engine="reference"); r.table(5)',
             'r = nss.run(".proc ic\\n halt\\n", engine="reference"); r.table("ilp", top="x")',
             'r = nss.run(".proc ic\\n halt\\n", engine="reference"); r.table("stalls", proc="ic")',
             'r = nss.run(".proc ic\\n halt\\n", engine="reference"); r.registers(None)',
             'r = nss.run(".proc ic\\n halt\\n", engine="reference"); r.table("diff", other=3)',
             'nss.run({"m": "x.s"})', 'nss.run("nosuch.s")', 'nss.assemble("nosuch.s")',
             'nss.render("tetra", res=2, pes=0)', 'nss.render("tetra", res=2, precision="fp16")']


def _api_cases() -> list[Case]:
    """The Python API with wrong types and values (issue 46, Why 8)."""
    flat = b"processors 5\nprocessors.pe0.ic.cycles.sub 3\n"
    return [Case("api", f"api-{i}", ("api",), {"stats.txt": flat}, python=code)
            for i, code in enumerate(API_CALLS)]


CACHE_STATES = {
    "dangling-entry": "(root / KEY).symlink_to(outside / 'entry')",
    "file-entry": "(root / KEY).write_text('x')",
    "garbage-nbi": "(root / KEY / '__pycache__').mkdir(parents=True); "
                   "(root / KEY / '__pycache__' / 'a.nbi').write_bytes(b'17\\n' + b'x' * 40)",
    "pickle-nbi": "(root / KEY / '__pycache__').mkdir(parents=True); "
                  "(root / KEY / '__pycache__' / 'a.nbi').write_bytes(b'\\x80\\x04garbage')",
    "linked-pycache": "(root / KEY).mkdir(); (root / KEY / '__pycache__').symlink_to(outside)",
    "linked-nbi": "(root / KEY / '__pycache__').mkdir(parents=True); "
                  "(root / KEY / '__pycache__' / 'a.nbi').symlink_to(outside / 'secret')",
    "bad-checksums": "(root / KEY / '__pycache__').mkdir(parents=True); "
                     "(root / KEY / 'checksums.json').write_text('{')",
    "linked-probe": "(root / '.writable').symlink_to(outside / 'created')",
}


CACHE_CASE = """import os
from pathlib import Path
from netsushisen.emulator.compiled import build
KEY = "0123456789abcdef"
here = Path.cwd()
root = here / "cache" / "compiled"
root.mkdir(parents=True)
outside = here / "outside"
outside.mkdir()
(outside / "secret").write_text("keep")
{state}
os.environ["NETSUSHISEN_CACHE"] = str(here / "cache")
assert build._cache_root() == root
entry = build._entry(root, KEY)
build.verify_cache(entry)
assert entry.is_dir() and not entry.is_symlink()
assert sorted(p.name for p in outside.iterdir()) == ["secret"], "a write outside the cache"
assert (outside / "secret").read_text() == "keep"
assert build.verify_cache(entry) is None, "not healed"
"""


def _cache_cases() -> list[Case]:
    """Cache entries not as the cache wrote them (issue 46, Why 5-6): each is discarded and
    rebuilt, nothing outside the cache is written (the checks are the case's asserts)."""
    return [Case("cache", f"cache-{name}", ("cache",), {}, python=CACHE_CASE.format(state=state))
            for name, state in CACHE_STATES.items()]


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
    out += _linear_cases(rng, per_category // 2) + _api_cases() + _cache_cases()
    if stats_base is not None:
        out += _number_cases(rng, stats_base)
    obj = _base_object()
    obj["bundles"][0][0][3] = 2 ** 70
    regressions = [c if c.name != "2**70" else Case(c.category, c.name, c.argv,
                                                   {"prog.o": json.dumps(obj).encode()})
                   for c in REGRESSIONS]
    return out + regressions
