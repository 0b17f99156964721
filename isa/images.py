"""Memory images: what the host writes into the machine before a run (`netsushisen run --image`).

The encoding lives in isa/, below both sides: the host side builds images (host/databases.py)
and the machine loads them (emulator/machine.py), and neither imports the other.

Two file formats carry the same content.

JSON (hand-written tests and small examples)::

    {
      "format": "netsushisen-image", "version": 1,          (both optional)
      "os.local":    [1, 2, 3.5],                            words from local address 0
      "ic.resident": {"at": 16, "words": [0.25, "0x3f800000"]},
      "icgm":        [{"at": 0, "words": [...]}, {"at": 512, "words": [...]}],
      "scgm":        [...],
      "pe1.os.local": [...],                                 one PE only (after the shared key)
      "host":        [{"header": {"length": 2, "dest": "os", "cls": 0, "tag": 1}}, 7, 8],
      "sizes":       {"icgm": 4096, "scgm": 1024},           global memory words (default:
                                                             highest word written + 1)
      "frame":       {"width": 64, "height": 64},            COL's frame buffer
      "regions":     {"ic.global": [[0, 512, "primitive_list", null],
                                    [512, 516, "shape_data", 0], ...]}
    }

Memory keys: `os.local`, `ic.local`, `sc.local`, `ic.resident`, `sc.resident` (each optionally
prefixed `peN.`), `icgm`, `scgm` (shared by all PEs), and `host`: the primary-ray stream DIS
hands out, a sequence of messages (a header word, isa/ring.py, then `length` payload words).
A value is a list of words (placed from address 0), an object {"at": address, "words": [...]},
or a list of such objects. A word is a JSON integer (a 32-bit integer), a JSON float (rounded
to the machine's precision), a string "0x..." (a raw word, bit for bit), "nan"/"inf"/"-inf", or
{"header": {"length", "dest" (os/ic/sc/col or 0..3), "cls", "tag"}}. Region keys are
`<proc>.local`, `<proc>.resident`, `<proc>.global` (IC's or SC's view of ICGM/SCGM); a region
is [start, end (exclusive), name, primitive id or null] (emulator/memories.py says what is
counted). Program `.data` words are loaded first; image words for the same local memory
overwrite them.

NPZ (`numpy.savez`, for the host side's large databases): one array per memory key (same
names; `name@N` places it at address N); integer arrays hold integers, float arrays floats,
uint32/uint64 arrays raw words; `frame` = [width, height]; `sizes.icgm`, `sizes.scgm` scalars;
`regions.<proc>.<space>` an (n, 4) integer array [start, end, name code, primitive or −1] with
name codes 0 voxel_data, 1 primitive_list, 2 shape_data, 3 luminance_data.
"""

from __future__ import annotations

import json
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from netsushisen.isa.errors import Diagnostic, NetsushisenError
from netsushisen.isa.regions import REGION_NAMES, Region, RegionMap
from netsushisen.isa.ring import DESTS, make_header
from netsushisen.isa.words import WordFormat, wrap32

IMAGE_FORMAT = "netsushisen-image"
_MEMORY_KEY = re.compile(r"^(?:pe(\d+)\.)?(os\.local|ic\.local|sc\.local|ic\.resident|sc\.resident)$")
_REGION_KEY = re.compile(r"^(os|ic|sc)\.(local|resident|global)$")

Chunk = tuple[str, np.ndarray]  # kind ('i' integer, 'f' float, 'w' raw word), values


@dataclass
class Segment:
    at: int
    chunks: list[Chunk]

    def __len__(self) -> int:
        return sum(len(a) for _, a in self.chunks)

    def encode(self, wf: WordFormat) -> np.ndarray:
        parts = [encode(kind, values, wf) for kind, values in self.chunks]
        return np.concatenate(parts) if parts else np.zeros(0, dtype=wf.word_dtype)


def encode(kind: str, values: np.ndarray, wf: WordFormat) -> np.ndarray:
    """Values of one kind as raw words of the machine's precision."""
    if kind == "f":
        return np.asarray(values, dtype=wf.float_type).view(wf.word_dtype)
    v = np.asarray(values).astype(np.int64)
    if kind == "i":
        v = ((v + (1 << 31)) % (1 << 32)) - (1 << 31)  # wrap to 32 bits, keep the sign
        return v.astype(np.int32).astype(np.int64).view(np.uint64).astype(wf.word_dtype) \
            if wf.bytes == 8 else v.astype(np.int32).view(np.uint32)
    raw = np.asarray(values, dtype=np.uint64)
    if wf.bytes == 4 and raw.size and int(raw.max()) >> 32:
        raise ValueError(f"raw word {int(raw.max()):#x} is wider than a 32-bit (fp32) machine word")
    return raw.astype(wf.word_dtype)


@dataclass
class MemoryImage:
    memories: dict[str, list[Segment]] = field(default_factory=dict)
    host: list[Segment] = field(default_factory=list)
    sizes: dict[str, int] = field(default_factory=dict)
    frame: tuple[int, int] | None = None
    regions: dict[str, list[Region]] = field(default_factory=dict)
    source: str = "<image>"

    # -- what the machine asks ---------------------------------------------------------------

    def _encode(self, seg: Segment, key: str, wf: WordFormat) -> np.ndarray:
        try:
            return seg.encode(wf)
        except ValueError as err:
            raise NetsushisenError(Diagnostic(f"{key}: {err}", file=self.source)) from None

    def _place(self, dest: np.ndarray, key: str, wf: WordFormat, limit_name: str) -> None:
        for seg in self.memories.get(key, []):
            words = self._encode(seg, key, wf)
            if seg.at < 0 or seg.at + len(words) > len(dest):
                raise NetsushisenError(Diagnostic(
                    f"{key}: {len(words)} words at {seg.at} do not fit in {limit_name} "
                    f"({len(dest)} words)", file=self.source))
            dest[seg.at:seg.at + len(words)] = words

    def fill(self, pe: int, stage: str, local: np.ndarray, resident: np.ndarray | None,
             wf: WordFormat | None = None) -> None:
        wf = wf or _format_of(local)
        for key in (f"{stage}.local", f"pe{pe}.{stage}.local"):
            self._place(local, key, wf, f"{stage}.local_words")
        for key in (f"{stage}.resident", f"pe{pe}.{stage}.resident"):
            if key in self.memories:
                if resident is None:
                    raise NetsushisenError(Diagnostic(f"{key}: OS has no resident memory",
                                                      file=self.source))
                self._place(resident, key, wf, f"{stage}_memory resident size")

    def global_memory(self, name: str, wf: WordFormat) -> np.ndarray:
        segs = self.memories.get(name, [])
        size = self.sizes.get(name, max((s.at + len(s) for s in segs), default=0))
        out = np.zeros(size, dtype=wf.word_dtype)
        self._place(out, name, wf, f"{name} (sizes.{name} = {size})")
        return out

    def host_words(self, wf: WordFormat) -> list[int]:
        out: list[int] = []
        for seg in self.host:
            out.extend(int(w) for w in self._encode(seg, "host", wf))
        return out

    def region_maps(self, stage: str) -> dict[str, RegionMap]:
        out = {}
        for space in ("local", "resident", "global"):
            regs = self.regions.get(f"{stage}.{space}")
            if regs:
                try:
                    out[space] = RegionMap(regs)
                except ValueError as err:
                    raise NetsushisenError(Diagnostic(f"regions.{stage}.{space}: {err}",
                                                      file=self.source)) from None
        return out


def _format_of(a: np.ndarray) -> WordFormat:
    return WordFormat("fp32" if a.dtype == np.uint32 else "fp64")


# ---------------------------------------------------------------------------------------------
# Reading files


def load_image(path: str | Path) -> MemoryImage:
    p = Path(path)
    if not p.is_file():
        raise NetsushisenError(Diagnostic("no such memory image", file=str(p)))
    if p.suffix == ".npz":
        return _load_npz(p)
    try:
        from netsushisen.isa import numbers

        data = numbers.loads(p.read_text(encoding="utf-8"), finite=False)
        bad = numbers.first_problem(data, finite=False)
        if bad:
            raise NetsushisenError(Diagnostic(f"{bad[0]}: {bad[1]}", file=str(p)))
    except RecursionError:
        raise NetsushisenError(Diagnostic("not valid JSON: nested too deeply", file=str(p))) from None
    except json.JSONDecodeError as err:
        raise NetsushisenError(Diagnostic(f"not valid JSON: {err.msg}", file=str(p),
                                          line=err.lineno, col=err.colno)) from None
    except UnicodeDecodeError:
        raise NetsushisenError(Diagnostic("not a JSON or .npz memory image", file=str(p))) from None
    return image_from_json(data, str(p))


def image_from_json(data: Any, source: str = "<image>") -> MemoryImage:
    def bad(msg: str) -> NetsushisenError:
        return NetsushisenError(Diagnostic(msg, file=source))

    if not isinstance(data, dict):
        raise bad("a memory image is a JSON object")
    if "format" in data and data["format"] != IMAGE_FORMAT:
        raise bad(f"format {data['format']!r} is not {IMAGE_FORMAT!r}")
    if data.get("version", 1) != 1:
        raise bad(f"image version {data.get('version')!r} is not 1")
    img = MemoryImage(source=source)
    for key, value in data.items():
        if key in ("format", "version"):
            continue
        if key == "frame":
            try:
                img.frame = (int(value["width"]), int(value["height"]))
            except (TypeError, KeyError, ValueError):
                raise bad('frame: expected {"width": W, "height": H}') from None
        elif key == "sizes":
            if not isinstance(value, dict) or set(value) - {"icgm", "scgm"}:
                raise bad('sizes: expected {"icgm": words, "scgm": words}')
            img.sizes = {k: _int(v, f"sizes.{k}", bad) for k, v in value.items()}
        elif key == "regions":
            img.regions = _regions_json(value, bad)
        elif key == "host":
            img.host = _segments(value, key, bad)
        elif key in ("icgm", "scgm") or _MEMORY_KEY.match(key):
            img.memories[key] = _segments(value, key, bad)
        else:
            raise bad(f"unknown key {key!r} (memories: os.local, ic.local, sc.local, ic.resident, "
                      "sc.resident, icgm, scgm, host; also sizes, frame, regions)")
    return img


def _int(v: Any, where: str, bad) -> int:
    if isinstance(v, bool) or not isinstance(v, int):
        raise bad(f"{where}: expected an integer, got {v!r}")
    return v


def _segments(value: Any, key: str, bad) -> list[Segment]:
    if isinstance(value, dict):
        value = [value]
    if isinstance(value, list) and value and all(isinstance(v, dict) and "words" in v for v in value):
        segs = []
        for i, v in enumerate(value):
            at = _int(v.get("at", 0), f"{key}[{i}].at", bad)
            segs.append(Segment(at, _words(v["words"], f"{key}[{i}]", bad)))
        return segs
    if not isinstance(value, list):
        raise bad(f"{key}: expected a list of words or {{\"at\": N, \"words\": [...]}}")
    return [Segment(0, _words(value, key, bad))]


def _words(items: Any, where: str, bad) -> list[Chunk]:
    if not isinstance(items, list):
        raise bad(f"{where}: expected a list of words")
    chunks: list[tuple[str, list]] = []
    for i, w in enumerate(items):
        kind, v = _word(w, f"{where}: word {i}", bad)
        if chunks and chunks[-1][0] == kind:
            chunks[-1][1].append(v)
        else:
            chunks.append((kind, [v]))
    return [(k, np.array(v, dtype=np.float64 if k == "f" else (np.uint64 if k == "w" else np.int64)))
            for k, v in chunks]


def _word(w: Any, where: str, bad) -> tuple[str, int | float]:
    if isinstance(w, bool):
        raise bad(f"{where}: booleans are not words")
    if isinstance(w, int):
        if not -(1 << 31) <= w < (1 << 32):
            raise bad(f"{where}: integer {w} does not fit in 32 bits")
        return "i", wrap32(w)
    if isinstance(w, float):
        return "f", w
    if isinstance(w, str):
        s = w.strip().lower()
        if s in ("nan", "inf", "+inf", "-inf"):
            return "f", float(s)
        if s.startswith("0x"):
            try:
                v = int(s, 16)
            except ValueError:
                raise bad(f"{where}: bad raw word {w!r}") from None
            if v >= 1 << 64:
                raise bad(f"{where}: raw word {w!r} is wider than 64 bits")
            return "w", v
        raise bad(f"{where}: expected an integer, a float, \"0x...\" or a header, got {w!r}")
    if isinstance(w, dict) and set(w) == {"header"} and isinstance(w["header"], dict):
        h = w["header"]
        try:
            dest = h.get("dest", 0)
            dest = DESTS[dest] if isinstance(dest, str) else int(dest)
            return "i", wrap32(make_header(int(h.get("length", 0)), dest, int(h.get("cls", 0)),
                                           int(h.get("tag", 0))))
        except (KeyError, ValueError, TypeError) as err:
            raise bad(f"{where}: bad header {h!r}: {err}") from None
    raise bad(f"{where}: expected an integer, a float, \"0x...\" or a header, got {w!r}")


def _regions_json(value: Any, bad) -> dict[str, list[Region]]:
    if not isinstance(value, dict):
        raise bad("regions: expected {\"<proc>.<space>\": [[start, end, name, primitive], ...]}")
    out = {}
    for key, items in value.items():
        key = {"icgm": "ic.global", "scgm": "sc.global"}.get(key, key)
        if not _REGION_KEY.match(key):
            raise bad(f"regions: unknown memory {key!r} (use os.local, ic.resident, ic.global, ...)")
        regs = []
        for i, r in enumerate(items if isinstance(items, list) else [None]):
            if isinstance(r, dict):
                r = [r.get("start"), r.get("end"), r.get("name"), r.get("primitive")]
            if not (isinstance(r, list) and len(r) in (3, 4) and isinstance(r[2], str)):
                raise bad(f"regions.{key}[{i}]: expected [start, end, name, primitive or null]")
            prim = r[3] if len(r) == 4 else None
            regs.append(Region(_int(r[0], f"regions.{key}[{i}]", bad),
                               _int(r[1], f"regions.{key}[{i}]", bad), r[2],
                               None if prim is None else _int(prim, f"regions.{key}[{i}]", bad)))
        out[key] = regs
    return out


def _load_npz(p: Path) -> MemoryImage:
    def bad(msg: str) -> NetsushisenError:
        return NetsushisenError(Diagnostic(msg, file=str(p)))

    try:
        z = np.load(p, allow_pickle=False)
    except (OSError, ValueError) as err:
        raise bad(f"not a readable .npz file: {err}") from None
    img = MemoryImage(source=str(p))
    with z:
        for key in z.files:
            a = z[key]
            if key == "frame":
                img.frame = (int(a[0]), int(a[1]))
            elif key.startswith("sizes."):
                img.sizes[key[6:]] = int(a)
            elif key.startswith("regions."):
                rk = key[8:]
                if not _REGION_KEY.match(rk) or a.ndim != 2 or a.shape[1] != 4:
                    raise bad(f"{key}: expected regions.<proc>.<space> as an (n, 4) array")
                img.regions[rk] = [Region(int(s), int(e), REGION_NAMES[int(n)],
                                          None if int(q) < 0 else int(q)) for s, e, n, q in a]
            else:
                name, _, at = key.partition("@")
                if not (name in ("icgm", "scgm", "host") or _MEMORY_KEY.match(name)):
                    raise bad(f"unknown array {key!r}")
                kind = "f" if a.dtype.kind == "f" else ("w" if a.dtype.kind == "u" else "i")
                seg = Segment(int(at or 0), [(kind, a.ravel())])
                if name == "host":
                    img.host.append(seg)
                else:
                    img.memories.setdefault(name, []).append(seg)
    return img
