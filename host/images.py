"""PNG files without Pillow: an 8-bit writer (zlib + struct) and a reader for tests and tools.

The writer emits grey (H, W), RGB (H, W, 3) or RGBA (H, W, 4) uint8 images, filter type 0 on
every row. The reader accepts any 8-bit non-interlaced grey / grey+alpha / RGB / RGBA PNG with
any of the five row filters, which covers what this project and common tools write.
"""

from __future__ import annotations

import struct
import zlib
from pathlib import Path

import numpy as np

from netsushisen.isa.errors import Diagnostic, NetsushisenError
from netsushisen.isa.outputs import write_bytes

_SIGNATURE = b"\x89PNG\r\n\x1a\n"
_COLOR_TYPES = {1: 0, 2: 4, 3: 2, 4: 6}  # channels -> PNG colour type
_CHANNELS = {v: k for k, v in _COLOR_TYPES.items()}


def _chunk(tag: bytes, data: bytes) -> bytes:
    return struct.pack(">I", len(data)) + tag + data + struct.pack(">I", zlib.crc32(tag + data) & 0xFFFFFFFF)


def encode_png(image: np.ndarray) -> bytes:
    """PNG bytes of a uint8 image (H, W), (H, W, 1|2|3|4)."""
    img = np.asarray(image)
    if img.dtype != np.uint8:
        raise ValueError(f"PNG writer wants uint8 pixels, got {img.dtype}")
    if img.ndim == 2:
        img = img[:, :, None]
    if img.ndim != 3 or img.shape[2] not in _COLOR_TYPES:
        raise ValueError(f"PNG writer wants (H, W) or (H, W, 1..4), got shape {img.shape}")
    h, w, c = img.shape
    header = struct.pack(">IIBBBBB", w, h, 8, _COLOR_TYPES[c], 0, 0, 0)
    rows = np.concatenate([np.zeros((h, 1), np.uint8), img.reshape(h, w * c)], axis=1)
    return (_SIGNATURE + _chunk(b"IHDR", header) + _chunk(b"IDAT", zlib.compress(rows.tobytes(), 9))
            + _chunk(b"IEND", b""))


def write_png(path: str | Path, image: np.ndarray) -> None:
    write_bytes(path, encode_png(image))


def _unfilter(raw: bytes, h: int, w: int, c: int) -> np.ndarray:
    stride = w * c
    data = np.frombuffer(raw, np.uint8).reshape(h, stride + 1)
    out = np.zeros((h, stride), np.int32)
    prev = np.zeros(stride, np.int32)
    for y in range(h):
        f, line = data[y, 0], data[y, 1:].astype(np.int32)
        if f == 0:
            row = line
        elif f == 2:
            row = (line + prev) & 0xFF
        elif f in (1, 3, 4):
            row = np.zeros(stride, np.int32)
            for x in range(stride):
                a = row[x - c] if x >= c else 0
                b = prev[x]
                if f == 1:
                    pred = a
                elif f == 3:
                    pred = (a + b) // 2
                else:
                    cc = prev[x - c] if x >= c else 0
                    p = a + b - cc
                    pa, pb, pc = abs(p - a), abs(p - b), abs(p - cc)
                    pred = a if pa <= pb and pa <= pc else (b if pb <= pc else cc)
                row[x] = (line[x] + pred) & 0xFF
        else:
            raise ValueError(f"unknown PNG row filter {f}")
        out[y] = row
        prev = row
    return out.astype(np.uint8).reshape(h, w, c)


def decode_png(data: bytes, name: str = "<png>") -> np.ndarray:
    """uint8 array (H, W, channels) of an 8-bit non-interlaced PNG."""
    def bad(msg: str) -> NetsushisenError:
        return NetsushisenError(Diagnostic(f"not a supported PNG: {msg}", file=name))

    if not data.startswith(_SIGNATURE):
        raise bad("missing PNG signature")
    pos, idat, header = len(_SIGNATURE), [], None
    while pos + 8 <= len(data):
        length, tag = struct.unpack(">I4s", data[pos:pos + 8])
        body = data[pos + 8:pos + 8 + length]
        pos += 12 + length
        if tag == b"IHDR":
            header = struct.unpack(">IIBBBBB", body)
        elif tag == b"IDAT":
            idat.append(body)
        elif tag == b"IEND":
            break
    if header is None:
        raise bad("no IHDR chunk")
    w, h, depth, ctype, _, _, interlace = header
    if depth != 8 or ctype not in _CHANNELS or interlace:
        raise bad(f"bit depth {depth}, colour type {ctype}, interlace {interlace}")
    try:
        raw = zlib.decompress(b"".join(idat))
    except zlib.error as err:
        raise bad(str(err)) from None
    return _unfilter(raw, h, w, _CHANNELS[ctype])


def read_png(path: str | Path) -> np.ndarray:
    return decode_png(Path(path).read_bytes(), str(path))
