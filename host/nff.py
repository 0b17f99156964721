"""NFF (Neutral File Format) reader and writer.

The reader treats a file as a stream of whitespace-separated tokens and lets each record's keyword
decide how many numbers it takes, because NFF producers disagree about line breaks inside a record
(the `c` record is written on one line by SPD 3.14 and on three lines by the original NFF
description). Tokens are found with one `str.split()` of the whole text; a token's line and column
are worked out only when something is wrong, so a good file costs almost nothing extra and a bad
one still gets a compiler-style `file:line:col: error:` message naming the record.

Decisions the NFF description leaves open, made here:

* An object (`p`, `pp`, `s`, `c`) before the first `f` record is an error, not a default
  material: the renderer would otherwise have to invent Kd/Ks/T, which decide how many rays a
  scene spawns, and a silent guess would skew every count downstream.
* A missing `b` record means a black background. A missing `v` block is an error (no camera).
* `v`, `b` may appear only once; lights and materials may appear anywhere.
* The `v` sub-keywords are accepted in any order but each exactly once, and all six are required.
* NaN, infinity, numbers that overflow to infinity, non-ASCII characters outside comments and
  non-UTF-8 bytes are errors. `#` starts a comment that runs to the end of the line.
* A `c` record with equal radii is a cylinder (`Kind.CYLINDER`), otherwise a cone (`Kind.CONE`).

Geometry is checked per record (host/nff_geometry.py: which problems are errors, which are
warnings, and why).

Records go into a `SceneBuilder` (`nff_builder`), which the SPD generators write through too.
`format_nff` writes a `Scene` back as NFF with C `%g` formatting (the SPD generators' own), with
an `f` record wherever the material changes; reading and re-writing an SPD file reproduces it byte
for byte unless the file repeats an unchanged `f` record.
"""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np

from netsushisen.isa.errors import Diagnostic, NetsushisenError, SceneError
from netsushisen.isa.outputs import write_text
from netsushisen.host.nff_builder import SceneBuilder
from netsushisen.host.nff_geometry import (FP32_EPS, MAX_WARNINGS, GeometryChecks, fp32_half_spacing,  # noqa: F401
                                           scene_warnings)
from netsushisen.host.scenes import Kind, Scene

RECORD_NAMES = {
    "b": "background record 'b'",
    "v": "view block 'v'",
    "l": "light record 'l'",
    "f": "material record 'f'",
    "p": "polygon record 'p'",
    "pp": "patch record 'pp'",
    "s": "sphere record 's'",
    "c": "cone/cylinder record 'c'",
}
VIEW_KEYWORDS = ("from", "at", "up", "angle", "hither", "resolution")
_KEYWORDS = frozenset(RECORD_NAMES) | frozenset(VIEW_KEYWORDS)
_COMMENT = re.compile(r"#[^\n]*")
_TOKEN = re.compile(r"\S+")
_MAX_SHOWN = 160  # longest source line quoted in a diagnostic



# ------------------------------------------------------------------------------------------------
# Reader
# ------------------------------------------------------------------------------------------------

def read_nff(path: str | Path) -> Scene:
    """Read an NFF file. Any problem with the file (missing, unreadable, malformed) is a
    `SceneError` located at the offending record."""
    from netsushisen.isa.limits import check_primitives, read_input

    path = Path(path)
    try:
        data = read_input(path, "scene file")
    except OSError as err:
        raise SceneError(Diagnostic(f"cannot read scene file: {err.strerror or err}",
                                    file=str(path))) from None
    scene = parse_nff(data, filename=str(path))
    check_primitives(scene.n_primitives, str(path))
    return scene


def parse_nff(text: str | bytes, filename: str = "<string>") -> Scene:
    """Parse NFF text (str, or bytes that must be UTF-8) into a `Scene` named after the file."""
    if isinstance(text, (bytes, bytearray)):
        text = _decode(bytes(text), filename)
    return _Parser(text, filename).parse()


def _decode(data: bytes, filename: str) -> str:
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as err:
        line_start = data.rfind(b"\n", 0, err.start) + 1
        line_end = data.find(b"\n", err.start)
        raw = data[line_start:line_end if line_end >= 0 else len(data)]
        col = len(data[line_start:err.start].decode("utf-8", "replace")) + 1
        raise SceneError(Diagnostic(
            f"not an NFF text file: byte 0x{data[err.start]:02x} is not valid UTF-8",
            file=filename, line=data.count(b"\n", 0, err.start) + 1, col=col,
            source_line=_shown(raw.decode("utf-8", "replace"), col))) from None


def _shown(line: str, col: int | None) -> str | None:
    """A source line safe to print on any terminal: control and non-ASCII characters shown as
    '?' (one character each, so columns still line up), very long lines cut."""
    line = "".join(ch if (ch.isascii() and ch.isprintable()) or ch == "\t" else "?"
                   for ch in line[:_MAX_SHOWN + 1])
    if len(line) > _MAX_SHOWN:
        if col is not None and col > _MAX_SHOWN:
            return None
        line = line[:_MAX_SHOWN] + "..."
    return line


def _is_number(tok: str) -> bool:
    try:
        float(tok)
    except ValueError:
        return False
    return "_" not in tok


class _Parser(GeometryChecks):
    def __init__(self, text: str, filename: str):
        if "\r" in text:
            text = text.replace("\r\n", "\n").replace("\r", "\n")
        self.filename = filename
        self.raw = text
        self.text = _COMMENT.sub("", text) if "#" in text else text
        self.tokens = self.text.split()
        self.pos = 0
        self.builder = SceneBuilder()
        self.first_pos: dict[str, int] = {}  # keyword -> token index of its first record
        self.init_checks()
        self.strict_tokens = "_" in self.text  # Python's float() accepts "1_0"; NFF does not

    # -- locating ---------------------------------------------------------------------------------
    def locate(self, index: int) -> tuple[int, int, str]:
        """(line, display column, source line) of token `index`: only computed on error."""
        seen = 0
        stripped = self.text.split("\n")
        for lineno, line in enumerate(stripped):
            n = len(line.split())
            if seen + n > index:
                match = list(_TOKEN.finditer(line))[index - seen]
                col = len(line[:match.start()].expandtabs(8)) + 1
                raw_lines = self.raw.split("\n")
                return lineno + 1, col, raw_lines[lineno].expandtabs(8)
            seen += n
        last = len(stripped)
        return last, 1, ""

    def error(self, message: str, index: int | None = None) -> SceneError:
        if index is None:
            return SceneError(Diagnostic(message, file=self.filename))
        if index >= len(self.tokens):  # end of file: point after the last token
            if not self.tokens:
                return SceneError(Diagnostic(message, file=self.filename))
            line, col, src = self.locate(len(self.tokens) - 1)
            col += len(self.tokens[-1])
        else:
            line, col, src = self.locate(index)
        shown = _shown(src, col)
        return SceneError(Diagnostic(message, file=self.filename, line=line,
                                     col=col if shown is not None else None, source_line=shown))

    # -- token helpers --------------------------------------------------------------------------
    def numbers(self, n: int, record: int, what: str, unit: str = "") -> list[float]:
        """Take the next `n` tokens as finite numbers; `record` is the keyword's token index."""
        start = self.pos
        chunk = self.tokens[start:start + n]
        try:
            values = list(map(float, chunk))
        except ValueError:
            values = None
        underscore = self.strict_tokens and any("_" in t for t in chunk)
        if values is None or len(chunk) < n or underscore:
            for j, tok in enumerate(chunk):
                if not _is_number(tok):
                    if tok in _KEYWORDS:
                        raise self.error(f"{what} needs {n} numbers{unit}, got {j}", record)
                    raise self.error(f"{what}: expected a number, found '{_clip(tok)}'", start + j)
            raise self.error(f"{what} needs {n} numbers{unit}, got {len(chunk)} "
                             "(file ends inside the record)", record)
        if not all(map(math.isfinite, values)):
            j = next(i for i, v in enumerate(values) if not math.isfinite(v))
            raise self.error(f"{what}: '{_clip(chunk[j])}' is not a finite number "
                             "(NaN and infinity are not allowed)", start + j)
        self.pos = start + n
        return values

    def integer(self, record: int, what: str, name: str) -> tuple[int, int]:
        """Take the next token as an integer; returns (value, token index)."""
        i = self.pos
        if i >= len(self.tokens):
            raise self.error(f"{what} needs {name}, got end of file", record)
        tok = self.tokens[i]
        if tok in _KEYWORDS:
            raise self.error(f"{what} needs {name}, found record keyword '{tok}'", i)
        try:
            if "_" in tok:
                raise ValueError
            value = int(tok)
        except ValueError:
            raise self.error(f"{what}: {name} must be an integer, found '{_clip(tok)}'",
                             i) from None
        self.pos = i + 1
        return value, i

    def numeric_run(self, limit: int) -> int:
        """How many of the next tokens (up to `limit`) look like numbers."""
        k = 0
        toks = self.tokens
        while k < limit and self.pos + k < len(toks) and _is_number(toks[self.pos + k]):
            k += 1
        return k

    # -- records --------------------------------------------------------------------------------
    def parse(self) -> Scene:
        if not self.raw.strip():
            raise self.error("empty scene file (no NFF records)")
        if not self.text.isascii():
            idx = next(i for i, ch in enumerate(self.text) if not ch.isascii())
            line = self.text.count("\n", 0, idx) + 1
            line_start = self.text.rfind("\n", 0, idx) + 1
            col = len(self.text[line_start:idx].expandtabs(8)) + 1
            src = self.raw.split("\n")[line - 1].expandtabs(8)
            raise SceneError(Diagnostic(
                f"non-ASCII character U+{ord(self.text[idx]):04X} outside a comment "
                "(NFF is ASCII text)", file=self.filename, line=line, col=col,
                source_line=_shown(src, col)))
        if not self.tokens:
            raise self.error("empty scene file (only comments, no NFF records)")
        handlers = {"b": self.rec_b, "v": self.rec_v, "l": self.rec_l, "f": self.rec_f,
                    "p": self.rec_p, "pp": self.rec_pp, "s": self.rec_s, "c": self.rec_c}
        tokens = self.tokens
        n_tokens = len(tokens)
        while self.pos < n_tokens:
            kw = tokens[self.pos]
            handler = handlers.get(kw)
            if handler is None:
                raise self.unknown(kw)
            record = self.pos
            self.pos += 1
            handler(record)
        if self.builder.camera is None:
            raise self.error("no view block 'v' in the file (NFF needs 'v' followed by "
                             "from/at/up/angle/hither/resolution)")
        self.check_polygons()
        return self.builder.build(name=Path(self.filename).stem, source=self.filename,
                                  notes=self.warning_lines())

    def unknown(self, kw: str) -> SceneError:
        if _is_number(kw):
            return self.error(f"unexpected number '{_clip(kw)}' where a record keyword was "
                              "expected (too many numbers in the previous record?)", self.pos)
        if kw in VIEW_KEYWORDS:
            return self.error(f"'{kw}' outside a view block 'v' (or given twice in it)", self.pos)
        known = ", ".join(RECORD_NAMES)
        return self.error(f"unknown record keyword '{_clip(kw)}' (NFF records: {known}, "
                          "and # comments)", self.pos)

    def once(self, kw: str, record: int) -> None:
        first = self.first_pos.get(kw)
        if first is not None:
            line = self.locate(first)[0]
            raise self.error(f"second {RECORD_NAMES[kw]} (the first is on line {line})", record)
        self.first_pos[kw] = record

    def object_allowed(self, kw: str, record: int) -> None:
        if self.builder.current_material < 0:
            raise self.error(f"{RECORD_NAMES[kw]} comes before any material record 'f' "
                             "(give an 'f R G B Kd Ks Shine T ior' line first)", record)

    def rec_b(self, record: int) -> None:
        self.once("b", record)
        self.builder.set_background(*self.numbers(3, record, RECORD_NAMES["b"], " (R G B)"))

    def rec_v(self, record: int) -> None:
        self.once("v", record)
        seen: dict[str, tuple[list, int]] = {}
        tokens = self.tokens
        while self.pos < len(tokens) and tokens[self.pos] in VIEW_KEYWORDS \
                and tokens[self.pos] not in seen:
            key, at = tokens[self.pos], self.pos
            self.pos += 1
            what = f"'{key}' line of the view block 'v'"
            if key == "resolution":
                values = [self.integer(at, what, "an x resolution")[0],
                          self.integer(at, what, "a y resolution")[0]]
            else:
                values = self.numbers(3 if key in ("from", "at", "up") else 1, at, what)
            seen[key] = (values, at)
        missing = [k for k in VIEW_KEYWORDS if k not in seen]
        if missing:
            names = ", ".join(f"'{k}'" for k in missing)
            raise self.error(f"view block 'v' is missing {names} (it needs from, at, up, angle, "
                             "hither and resolution)", record)
        eye, at, up = (seen[k][0] for k in ("from", "at", "up"))
        for key in ("from", "at"):
            self.check_magnitude(seen[key][0], seen[key][1], f"'{key}' line of the view block 'v'")
        angle, hither = seen["angle"][0][0], seen["hither"][0][0]
        res = seen["resolution"][0]
        if not 0.0 < angle < 180.0:
            raise self.error(f"view angle must be between 0 and 180 degrees, got {angle:g}",
                             seen["angle"][1])
        if hither < 0.0:
            raise self.error(f"hither distance must not be negative, got {hither:g}",
                             seen["hither"][1])
        if res[0] < 1 or res[1] < 1:
            raise self.error(f"resolution must be positive, got {res[0]} {res[1]}",
                             seen["resolution"][1])
        direction = np.subtract(at, eye)
        if not np.any(direction):
            raise self.error("'from' and 'at' are the same point: no view direction",
                             seen["at"][1])
        if not np.any(np.cross(direction, up)):
            raise self.error("'up' is zero or parallel to the view direction", seen["up"][1])
        self.builder.set_camera(eye, at, up, angle, hither, (res[0], res[1]))

    def rec_l(self, record: int) -> None:
        what = RECORD_NAMES["l"]
        x, y, z = self.numbers(3, record, what, " (x y z)")
        self.check_magnitude([x, y, z], record, what)
        k = self.numeric_run(3)
        color = None
        if k:
            if k < 3:
                raise self.error(f"{what}: the optional colour needs 3 numbers (R G B), got {k}",
                                 record)
            color = self.numbers(3, record, what + " colour")
        self.builder.add_light(x, y, z, color)

    def rec_f(self, record: int) -> None:
        self.builder.set_material(*self.numbers(8, record, RECORD_NAMES["f"],
                                                " (R G B Kd Ks Shine T ior)"))

    def vertex_count(self, kw: str, record: int) -> int:
        what = RECORD_NAMES[kw]
        n, at = self.integer(record, what, "a vertex count")
        if n < 3:
            raise self.error(f"{what} needs at least 3 vertices, got a vertex count of {n}", at)
        return n

    def rec_p(self, record: int) -> None:
        self.object_allowed("p", record)
        n = self.vertex_count("p", record)
        xyz = self.numbers(3 * n, record, f"{RECORD_NAMES['p']} with {n} vertices",
                           " (x y z per vertex)")
        self.check_polygon(xyz, record, RECORD_NAMES["p"])
        self.builder.add_polygon(xyz)

    def rec_pp(self, record: int) -> None:
        self.object_allowed("pp", record)
        n = self.vertex_count("pp", record)
        xyzn = self.numbers(6 * n, record, f"{RECORD_NAMES['pp']} with {n} vertices",
                            " (x y z nx ny nz per vertex)")
        self.check_magnitude(xyzn, record, RECORD_NAMES["pp"])
        self.check_polygon([x for i in range(0, 6 * n, 6) for x in xyzn[i:i + 3]], record,
                           RECORD_NAMES["pp"])
        self.builder.add_patch(xyzn)

    def rec_s(self, record: int) -> None:
        self.object_allowed("s", record)
        what = RECORD_NAMES["s"]
        x, y, z, r = self.numbers(4, record, what, " (x y z radius)")
        self.check_magnitude([x, y, z, r], record, what)
        if r <= 0.0:
            raise self.error(f"{what}: the radius must be positive, got {r:g}", record)
        self.check_round([x, y, z], r, record, what)
        self.builder.add_sphere(x, y, z, r)

    def rec_c(self, record: int) -> None:
        self.object_allowed("c", record)
        v = self.numbers(8, record, RECORD_NAMES["c"],
                         " (base x y z radius, apex x y z radius)")
        what = RECORD_NAMES["c"]
        self.check_magnitude(v, record, what)
        if v[0:3] == v[4:7]:
            raise self.error(f"{what} has the same base and apex point (no axis)", record)
        if v[3] < 0.0 or v[7] < 0.0:
            raise self.error(f"{what}: a radius must not be negative, got "
                             f"{v[3] if v[3] < 0.0 else v[7]:g}", record)
        if v[3] == 0.0 and v[7] == 0.0:
            raise self.error(f"{what}: both radii are zero (a line, never hit)", record)
        self.check_round(v[0:3], max(v[3], v[7]), record, what)
        axis = math.dist(v[0:3], v[4:7])
        if axis < fp32_half_spacing(max(map(abs, v[0:3] + v[4:7]))):
            raise self.error(f"{what}: its axis ({axis:g} long) is lost beside its position in "
                             "fp32 (the machine's precision)", record)
        self.builder.add_cone(*v)


def _clip(tok: str, width: int = 24) -> str:
    tok = "".join(ch if ch.isascii() and ch.isprintable() else "?" for ch in tok[:width + 1])
    return tok if len(tok) <= width else tok[:width] + "..."


# ------------------------------------------------------------------------------------------------
# Writer
# ------------------------------------------------------------------------------------------------

def _g(template: str, exact: bool) -> str:
    return template.replace("%g", "%s") if exact else template


def _n(values: tuple, exact: bool) -> tuple:
    return tuple(repr(float(v)) for v in values) if exact else values


def format_nff(scene: Scene, exact: bool = False) -> str:
    """The scene as NFF text, numbers in C `%g` (six significant digits, as the SPD wrote them),
    or with `exact` in the shortest text that reads back to the same float64 (a scene built in
    memory, e.g. moved by 1e5, must not lose its small offsets to six digits).

    `c` records are written on one line (SPD 3.14 layout); a light colour is written only when it
    is not the default white; an `f` record precedes each run of primitives sharing a material.
    """
    out: list[str] = [_g("b %g %g %g\n", exact) % _n(tuple(scene.background.tolist()), exact)]
    cam = scene.camera
    out.append(_g("v\nfrom %g %g %g\nat %g %g %g\nup %g %g %g\nangle %g\nhither %g\n", exact)
               % _n((*cam.eye.tolist(), *cam.at.tolist(), *cam.up.tolist(), cam.angle, cam.hither), exact)
               + "resolution %d %d\n" % tuple(cam.resolution))
    for pos, col in zip(scene.light_position.tolist(), scene.light_color.tolist()):
        if col == [1.0, 1.0, 1.0]:
            out.append(_g("l %g %g %g\n", exact) % _n(tuple(pos), exact))
        else:
            out.append(_g("l %g %g %g %g %g %g\n", exact) % _n((*pos, *col), exact))
    mats = scene.materials
    mat_rows = np.column_stack([mats.color, mats.kd, mats.ks, mats.shine, mats.t,
                                mats.ior]).tolist()
    polys, spheres, cones = scene.polygons, scene.spheres, scene.cones
    p_start, p_count = polys.start.tolist(), polys.count.tolist()
    p_patch = polys.is_patch.tolist()
    verts, norms = polys.vertices.tolist(), polys.normals.tolist()
    s_rows = np.column_stack([spheres.center, spheres.radius]).tolist()
    c_rows = np.column_stack([cones.base, cones.base_radius, cones.apex,
                              cones.apex_radius]).tolist()
    previous = -1
    for kind, mat, local in zip(scene.kind.tolist(), scene.material.tolist(),
                                scene.local_index.tolist()):
        if mat != previous:
            out.append(_g("f %g %g %g %g %g %g %g %g\n", exact) % _n(tuple(mat_rows[mat]), exact))
            previous = mat
        if kind == Kind.POLYGON:
            s, n = p_start[local], p_count[local]
            if p_patch[local]:
                out.append(f"pp {n}\n")
                out.extend(_g("%g %g %g %g %g %g\n", exact) % _n((*verts[i], *norms[i]), exact)
                           for i in range(s, s + n))
            else:
                out.append(f"p {n}\n")
                out.extend(_g("%g %g %g\n", exact) % _n(tuple(verts[i]), exact) for i in range(s, s + n))
        elif kind == Kind.SPHERE:
            out.append(_g("s %g %g %g %g\n", exact) % _n(tuple(s_rows[local]), exact))
        else:
            out.append(_g("c %g %g %g %g %g %g %g %g\n", exact) % _n(tuple(c_rows[local]), exact))
    return "".join(out)


def write_nff(scene: Scene, path: str | Path) -> None:
    """Write `format_nff(scene)` to `path`; an unwritable path is a `SceneError`."""
    try:
        write_text(path, format_nff(scene), encoding="ascii")
    except NetsushisenError as err:
        message = err.diagnostics[0].message.replace("cannot write:", "cannot write NFF file:")
        raise SceneError(Diagnostic(message, file=str(path))) from None
