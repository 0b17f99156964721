"""Figures 4 and 5 from one IC access stream: every memory configuration the paper sweeps, laid
out as the machine would lay it out (`host.databases.plan_layout` with the pre-pass priorities)
and replayed at once (`tracesim.SweepStream`). The stream is the golden trace's in the machine's
serial order (`golden_chunks`, the `paper` command's trace-driven path) or one the machine
recorded (`paper_machine.machine_chunks`, the ray-order study of `--on-machine`)."""

from __future__ import annotations

import copy

from netsushisen.emulator.tracesim import SweepPoint, SweepStream
from netsushisen.host.databases import plan_layout
from netsushisen.host.ic_access import ordered_stream_chunks, pe_orders
from netsushisen.isa.config import MachineConfig
from netsushisen.reports.paper_data import (CACHE_SHARES, LOCAL_SHARES, RESIDENT_SPLITS,
                                            PaperOptions, Progress)


def sized_config(config: MachineConfig, base_words: int, resident: float | None,
                 cache: float | None) -> MachineConfig:
    """`config` with IC's resident and cache sizes set to shares of `base_words` (the sized
    database), rounded as the machine rounds shares (resident: whole words, cache: whole blocks);
    a share of None keeps that memory's size in bytes as configured."""
    c = copy.deepcopy(config)
    mc = c.ic_memory
    wb = config.word_bytes
    if resident is not None:
        mc.resident_share = None
        mc.resident_bytes = int(resident * base_words) * wb
    if cache is not None:
        mc.cache_share = None
        size = int(cache * base_words * wb)
        mc.cache_bytes = size - size % mc.block_bytes
    return c


def sweep_points(config: MachineConfig) -> list[tuple[str, float, float]]:
    """(figure, local or cache share, resident split) of every configuration swept."""
    out = [("fig4", c, 0.0) for c in CACHE_SHARES]
    out += [("fig5", local, r) for local in LOCAL_SHARES for r in RESIDENT_SPLITS]
    return out


def golden_chunks(golden, rays_per_chunk: int = 16384, pes: int = 1):
    """The golden trace's IC stream in the machine's serial order, for `replay_figures`: a function of
    the reference layout giving (number of chunks, one stream of chunks per PE). `pes` > 1: the
    pixels divided among PEs as the machine's static distribution divides them
    (`host.ic_access.pe_orders`), each PE's rays in its own serial order."""
    orders = pe_orders(golden, pes)

    def chunks(reference):
        return (sum(max(1, -(-len(o) // rays_per_chunk)) for o in orders),
                [ordered_stream_chunks(reference, golden, o, rays_per_chunk) for o in orders])
    return chunks


def replay_figures(scene, chunks, pre, grid, config: MachineConfig, options: PaperOptions, label: str,
           progress: Progress) -> tuple[dict, list[dict], list[dict], int]:
    """Replay a stream through every memory configuration of Figures 4–5 under one reading:
    (database sizes, fig4 rows, fig5 rows, loads replayed). `chunks(reference layout)`: (number
    of chunks, per PE the stream in that layout in chunks that end between tests) — the golden
    trace's (`golden_chunks`) or the machine's recorded one (`machine_chunks`). Each PE's stream
    runs through memories of its own (its caches start cold); the counts are summed."""
    reference = plan_layout(scene, sized_config(config, 1, 0.0, 0.0), pre.priorities, grid)
    base = (reference.shape_words if options.sizing == "records"
            else reference.primitive_database_words)
    wb = config.word_bytes
    points: dict[tuple[int, int], SweepPoint] = {}
    chosen = []
    for fig, share, split in sweep_points(config):
        if fig == "fig4":
            cfg = sized_config(config, base, 0.0, share)
        else:
            cfg = sized_config(config, base, share * split, share * (1 - split))
        lay = plan_layout(scene, cfg, pre.priorities, grid)
        key = (lay.resident_count, lay.cache_bytes)
        if key not in points:
            points[key] = SweepPoint(lay, lay.cache_bytes, config.ic_memory.block_bytes)
        chosen.append((fig, share, split, lay.resident_capacity * wb, key))
    sweep = SweepStream(reference, list(points.values()), wb, lists_cached=options.lists == "cache")
    n_chunks, streams = chunks(reference)
    loads = i = 0
    what = f"{scene.name}: replay {len(points)} memory configurations{label}"
    for stream in streams:
        sweep.reset()
        for space, address in stream:
            progress(what, i, n_chunks)
            i += 1
            loads += len(address)
            sweep.replay(space, address)
    progress(what, n_chunks, n_chunks)
    mc = config.ic_memory
    fig4, fig5 = [], []
    for fig, share, split, resident_bytes, key in chosen:
        f = SweepStream.figures(points[key], mc.t_r, mc.t_c, mc.t_g)
        row = {"resident_bytes": resident_bytes, "resident_count": key[0], "cache_bytes": key[1],
               "all": f["all"], "shape": f["shape"], "ref": f["ref"]}
        if fig == "fig4":
            fig4.append({"cache_share": share} | row)
        else:
            fig5.append({"local_share": share, "resident_split": split} | row)
    sizes = {"database": reference.sizes(), "primitive_database_bytes": base * wb}
    return sizes, fig4, fig5, loads
