"""The IC access protocol as an address stream: which words IC loads, in which order, with which
instruction, for a sequence of intersection tests (docs/databases.md, "IC access protocol").

Per reference (one ray tested against one primitive of one leaf's list):

1. the list cell, 2 `ldg` in address order: priority P (negative on a leaf's last cell), shape
   pointer;
2. the shape record's *test words* (the kind/flags word, then the fields its intersection test
   uses) in ascending address order, with `ldr` when P <= M (resident memory) and `ldg` when
   P > M (ICGM through the cache).

After the last reference of a surface ray that hit something, IC reads the winner's *hit words*
(luminance pointer, primitive id, the fields its normals need; for a patch the vertex normals of
the hit's fan triangle) from the same memory, in ascending address order, for the HIT message
to SC (docs/kernels.md). Shadow rays read nothing more.

A trace-driven cache model (emulator/tracesim.py) replays this stream; the IC kernel follows it
word for word so that the emulator's counters equal the model's. `machine_order` gives the order
in which the machine's serial mode (`SLOTS=1`, `SERIAL_TREES=1`) visits the golden trace's rays,
and `ordered_stream_chunks` the stream in that order.
"""

from __future__ import annotations

from typing import Iterator

import numpy as np

from netsushisen.host.databases import GLOBAL, LIST_BASE, RESIDENT, DatabaseLayout, access_tables
from netsushisen.host.golden import SHADOW
from netsushisen.host.records import CELL_WORDS, patch_hit_offsets, ranges
from netsushisen.host.scenes import Kind


def cell_addresses(layout: DatabaseLayout, prims: np.ndarray, leaves: np.ndarray) -> np.ndarray:
    """ICGM address of the cell of primitive `prims[k]` in the list of leaf `leaves[k]`."""
    g = layout.grid
    n1 = layout.n_primitives + 1
    entry_leaf = np.repeat(np.arange(g.n_leaves, dtype=np.int64), np.diff(g.leaf_offsets))
    keys = entry_leaf * n1 + g.leaf_prims  # ascending: leaves in order, ids ascending within
    query = np.asarray(leaves, np.int64) * n1 + np.asarray(prims, np.int64)
    entry = np.searchsorted(keys, query)
    if len(keys):
        bad = (entry >= len(keys)) | (keys[np.minimum(entry, len(keys) - 1)] != query)
    else:
        bad = np.ones(len(query), bool)
    if np.any(bad):
        k = int(np.flatnonzero(bad)[0])
        raise ValueError(f"reference {k}: primitive {int(prims[k])} is not in the list of "
                         f"leaf {int(leaves[k])}")
    return LIST_BASE + CELL_WORDS * entry


def _record_words(layout: DatabaseLayout, table: tuple[np.ndarray, np.ndarray], prims: np.ndarray):
    """(space, address, words per primitive) of the table's words of each primitive in turn."""
    off, rel = table
    length = off[prims + 1] - off[prims]
    p = np.repeat(prims, length)
    return layout.record_space[p], layout.record_address[p] + rel[ranges(off[prims], length)], length


def _patch_words(layout: DatabaseLayout, prims: np.ndarray, fans: np.ndarray):
    """(words per hit, addresses) of the fan-dependent vertex normals of patch hits."""
    sd = layout.shapes
    poly = sd.kind[prims] == Kind.POLYGON
    patch = np.zeros(len(prims), bool)
    patch[poly] = sd.poly_is_patch[sd.local[prims[poly]]]
    nv = sd.poly_count[sd.local[prims[patch]]]
    rel = patch_hit_offsets(nv, fans[patch])
    return np.where(patch, rel.shape[1], 0), (layout.record_address[prims[patch]][:, None] + rel).ravel()


def ic_address_stream(layout: DatabaseLayout, trace_prims: np.ndarray, trace_leaves: np.ndarray,
                      ray_offsets: np.ndarray | None = None, ray_hits: np.ndarray | None = None,
                      ray_fans: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """(space (int8: GLOBAL = ldg/ICGM, RESIDENT = ldr), word address (int64)) of every IC load
    for the references (`trace_prims[k]` tested from the list of leaf `trace_leaves[k]`), in
    order. With `ray_offsets` (CSR of references per ray), `ray_hits` (per ray the hit
    primitive, -1 none) and `ray_fans` (the hit's fan triangle; needed for patches) — the golden
    trace's `trace_ray_offsets`, `trace_hit`, `trace_hit_fan` — the hit words of each winner
    follow its ray's last reference."""
    prims = np.asarray(trace_prims, np.int64)
    cells = cell_addresses(layout, prims, trace_leaves)
    tables = access_tables(layout)
    n = len(prims)
    # events: reference k (key 2k), and the hit of a ray after its last reference k (key 2k + 1)
    is_ref, ev_prim, ev_cell, ev_fan = np.ones(n, bool), prims, cells, np.zeros(n, np.int64)
    if ray_hits is not None:
        if ray_offsets is None:
            raise ValueError("ray_hits needs ray_offsets")
        off = np.asarray(ray_offsets, np.int64)
        hits = np.asarray(ray_hits, np.int64)
        fans = np.zeros(len(hits), np.int64) if ray_fans is None else np.asarray(ray_fans, np.int64)
        rays = np.flatnonzero(hits >= 0)
        if np.any(off[rays + 1] <= off[rays]):
            raise ValueError("a ray with a hit has no references")
        order = np.argsort(np.concatenate([2 * np.arange(n), 2 * (off[rays + 1] - 1) + 1]), kind="stable")
        k = len(rays)
        is_ref = np.concatenate([is_ref, np.zeros(k, bool)])[order]
        ev_prim = np.concatenate([prims, hits[rays]])[order]
        ev_cell = np.concatenate([cells, np.zeros(k, np.int64)])[order]
        ev_fan = np.concatenate([ev_fan, fans[rays]])[order]
    refs, wins = np.flatnonzero(is_ref), np.flatnonzero(~is_ref)
    t_space, t_addr, t_len = _record_words(layout, tables["test"], ev_prim[refs])
    h_space, h_addr, h_len = _record_words(layout, tables["hit"], ev_prim[wins])
    p_len, p_addr = _patch_words(layout, ev_prim[wins], ev_fan[wins])
    length = np.zeros(len(ev_prim), np.int64)
    length[refs] = CELL_WORDS + t_len
    length[wins] = h_len + p_len
    start = np.cumsum(length) - length
    space = np.full(int(length.sum()), GLOBAL, np.int8)
    address = np.zeros(len(space), np.int64)
    cell_pos = ranges(start[refs], np.full(len(refs), CELL_WORDS))
    address[cell_pos] = ranges(ev_cell[refs], np.full(len(refs), CELL_WORDS))
    pos = ranges(start[refs] + CELL_WORDS, t_len)
    space[pos], address[pos] = t_space, t_addr
    pos = ranges(start[wins], h_len)
    space[pos], address[pos] = h_space, h_addr
    pos = ranges(start[wins] + h_len, p_len)
    space[pos] = np.repeat(layout.record_space[ev_prim[wins]], p_len)
    address[pos] = p_addr
    return space, address


def golden_stream(layout: DatabaseLayout, result, hits: bool = True, rays: slice = slice(None)
                  ) -> tuple[np.ndarray, np.ndarray]:
    """The stream of a golden render kept with `keep_trace=True` (same grid as `layout`), for
    the rays `rays` (a slice of the trace's depth-first ray order) — a 512 x 512 trace gives
    hundreds of millions of loads, so replay it in chunks of rays (`golden_stream_chunks`)."""
    if result.trace_prims is None or result.trace_leaves is None:
        raise ValueError("render with keep_trace=True to get the IC reference trace")
    off = result.trace_ray_offsets
    r0, r1, _ = rays.indices(len(off) - 1)
    a, b = int(off[r0]), int(off[r1])
    if not hits:
        return ic_address_stream(layout, result.trace_prims[a:b], result.trace_leaves[a:b])
    return ic_address_stream(layout, result.trace_prims[a:b], result.trace_leaves[a:b],
                             off[r0:r1 + 1] - a, result.trace_hit[r0:r1], result.trace_hit_fan[r0:r1])


def golden_stream_chunks(layout: DatabaseLayout, result, hits: bool = True, rays_per_chunk: int = 65536):
    """`golden_stream` in consecutive chunks of rays (concatenated, they are the whole stream)."""
    n = len(result.trace_ray_offsets) - 1
    for r0 in range(0, n, rays_per_chunk):
        yield golden_stream(layout, result, hits, slice(r0, min(n, r0 + rays_per_chunk)))


# ------------------------------------------------------------------------------------------------
# The machine's ray order and the IC stream in that order


def ray_generation(result) -> np.ndarray:
    """Generation of each traced ray in its pixel's ray tree: the eye ray 0; a surface ray of
    depth k: k − 1; a shadow ray of a depth-k hit (it carries depth k): k."""
    depth = result.trace_depth.astype(np.int64)
    return np.where(result.trace_kind == SHADOW, depth, depth - 1)


def machine_order(result) -> np.ndarray:
    """The golden trace's ray indices in the order the machine's serial mode visits them: pixel
    by pixel, each pixel's ray tree in level order (the eye ray; its children in spawn order —
    shadow rays by light, reflection, refraction; then their children in the same order, ...).

    The trace is depth-first (rays sorted by their tree path); within one generation of one
    pixel, depth-first order and level order are the same order (both sort the equal-length
    paths lexicographically), so a stable sort by (pixel, generation) gives level order."""
    if result.trace_kind is None:
        raise ValueError("render with keep_trace=True to get the IC reference trace")
    return np.lexsort((ray_generation(result), result.trace_pixel)).astype(np.int64)


def pe_orders(result, pes: int = 1) -> list[np.ndarray]:
    """`machine_order` divided among `pes` PEs as the machine's static distribution divides
    the work (`distribution = "static"`: DIS hands eye sample i to PE i mod pes, and a pixel's
    whole ray tree stays in its PE's ring): per PE, its pixels' rays in its own serial order."""
    order = machine_order(result)
    if pes == 1:
        return [order]
    pe = result.trace_pixel[order] % pes
    return [order[pe == k] for k in range(pes)]


def ordered_stream_chunks(layout: DatabaseLayout, result, order: np.ndarray | None = None,
                          rays_per_chunk: int = 32768, hits: bool = True
                          ) -> Iterator[tuple[np.ndarray, np.ndarray]]:
    """The IC access stream (`ic_address_stream`) of the golden trace's rays taken in `order`
    (default: the trace's depth-first order), in chunks of rays."""
    if result.trace_prims is None:
        raise ValueError("render with keep_trace=True to get the IC reference trace")
    off = result.trace_ray_offsets
    n = len(off) - 1
    order = np.arange(n) if order is None else np.asarray(order, np.int64)
    for c0 in range(0, len(order), rays_per_chunk):
        rays = order[c0:c0 + rays_per_chunk]
        length = off[rays + 1] - off[rays]
        idx = ranges(off[rays], length)
        new_off = np.concatenate([[0], np.cumsum(length)])
        if hits:
            yield ic_address_stream(layout, result.trace_prims[idx], result.trace_leaves[idx],
                                    new_off, result.trace_hit[rays], result.trace_hit_fan[rays])
        else:
            yield ic_address_stream(layout, result.trace_prims[idx], result.trace_leaves[idx])


# ------------------------------------------------------------------------------------------------
# The machine's recorded stream (emulator/loads.py) read through a layout


def load_primitives(layout: DatabaseLayout, space: np.ndarray, address: np.ndarray
                    ) -> tuple[np.ndarray, np.ndarray]:
    """(primitive, word offset in its shape record) of each IC load in `layout`: a list cell
    (ICGM below `list_words`) gives primitive -1, offset its address. A load inside no record
    is a ValueError naming it (the stream is not of this layout)."""
    space = np.asarray(space)
    address = np.asarray(address, np.int64)
    prim = np.full(len(address), -1, np.int64)
    offset = address.copy()
    for sp in (GLOBAL, RESIDENT):
        sel = (space == sp) & ((address >= layout.list_words) if sp == GLOBAL else True)
        ids = np.flatnonzero(layout.record_space == sp)
        ids = ids[np.argsort(layout.record_address[ids], kind="stable")]
        starts = layout.record_address[ids]
        a = address[sel]
        k = np.searchsorted(starts, a, side="right") - 1
        p = ids[np.maximum(k, 0)] if len(ids) else np.zeros(len(a), np.int64)
        off = a - layout.record_address[p] if len(ids) else a
        bad = (k < 0) | (off >= layout.record_size[p]) if len(ids) else np.ones(len(a), bool)
        if np.any(bad):
            j = int(np.flatnonzero(bad)[0])
            where = "ICGM" if sp == GLOBAL else "resident memory"
            raise ValueError(f"load of {where} address {int(a[j])} is in no shape record")
        prim[sel], offset[sel] = p, off
    return prim, offset


def to_reference(layout: DatabaseLayout, reference: DatabaseLayout, space: np.ndarray,
                 address: np.ndarray) -> np.ndarray:
    """The ICGM address each IC load of `layout` has in `reference` (every record in ICGM, the
    same lists: `tracesim.SweepStream`'s layout): list cells keep theirs, a record's word moves
    with its record."""
    if reference.list_words != layout.list_words:
        raise ValueError("the two layouts have different primitive lists")
    prim, offset = load_primitives(layout, space, address)
    return np.where(prim >= 0, reference.record_address[np.maximum(prim, 0)] + offset, offset)
