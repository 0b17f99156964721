"""One way to run many runs: the Dask layer under `paper`, `accuracy`, `numerics` and `sweep`.

A multi-run command turns its independent runs (scenes, scene × axis units, catalog cases,
sweep points) into `Task`s and hands them to `run_tasks`, which

- runs them on a Dask LocalCluster (one single-threaded worker process per core, at most one
  per task, or `--workers N`) or, with `--scheduler tcp://HOST:PORT`, on the cluster whose scheduler listens
  there (`dask scheduler`, then `dask worker ADDRESS` on each machine): a user who outgrows one
  machine points any of these commands at a cluster;
- gives each result to the command by the task's index (`on_done`), so the command assembles its
  output in input order, never in completion order: the same inputs give the same files;
- passes what a task finishes before it returns (`emit`, e.g. each accuracy row) to `on_item`
  as it comes, through a Dask queue, so Ctrl-C loses only what was still running;
- shows one progress bar on standard error when it is a terminal (a command that logs, e.g.
  one line per finished run when it is not, does so in its `on_done`);
- on Ctrl-C stops the cluster and returns `interrupted`: the command writes what finished and
  exits 130. LocalCluster workers ignore SIGINT (Ctrl-C at a terminal reaches the whole process
  group), so no worker prints a traceback;
- refuses a scheduler address that is not `tcp://HOST:PORT` before anything starts, and one that
  does not speak Dask (nothing listening, an HTTP server, garbage) in one line: `cannot connect`.

`ResultCache` is the content-keyed store of finished results (a sweep's `points/KEY.json`,
`paper`'s and `accuracy`'s `runs/KEY.json`): written atomically with a checksum, read back
verified, so a rerun (after Ctrl-C, say) computes only what is missing and a damaged file is
named and computed again. `run_cached` is `run_tasks` through such a cache; a run's key hashes
everything its result is a function of (`content_key`).
"""

from __future__ import annotations

import argparse
import hashlib
import json
import logging
import os
import re
import signal
import sys
import time
import uuid
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable

from netsushisen.isa.errors import NetsushisenError
from netsushisen.isa.outputs import write_text

POLL = 0.1
"""Seconds between looks at finished tasks and emitted items."""
IN_PROCESS = False
"""The LocalCluster's workers as threads of this process (tests that patch the code a task runs
set it); the commands always use processes."""


# -- options ------------------------------------------------------------------------------------

def add_cluster_options(parser: argparse.ArgumentParser, what: str,
                        aliases: tuple[str, ...] = (), default: str = "one per core") -> None:
    """`--scheduler ADDRESS` and `--workers N` (`what`: the runs a worker takes, `default`: the
    command's default count, for the help)."""
    parser.add_argument("--scheduler", metavar="ADDRESS",
                        help="run on the Dask cluster whose scheduler listens at ADDRESS "
                             "(tcp://host:8786); default: a LocalCluster on this machine")
    parser.add_argument("--workers", *aliases, dest="workers", type=int, metavar="N",
                        help=f"LocalCluster worker processes, {what} (default: {default})")


def check_cluster_options(args: argparse.Namespace, flag: str = "--workers") -> None:
    """Refuse a worker count below 1, a malformed scheduler address and one where no Dask
    scheduler answers, before any work."""
    if args.workers is not None and args.workers < 1:
        raise NetsushisenError(f"{flag} {args.workers}: need at least 1 worker")
    if args.scheduler is not None:
        check_scheduler(args.scheduler)
        greeting(args.scheduler)  # a wrong address is found before any work starts


_ADDRESS = re.compile(r"(tcp|tls)://(\[[0-9A-Fa-f:.]+\]|[A-Za-z0-9.-]+):(\d{1,5})\Z")


def check_scheduler(address: str) -> None:
    """A Dask scheduler address, `tcp://HOST:PORT` (or tls://), refused in one line before
    anything starts otherwise."""
    m = _ADDRESS.match(address)
    if m is None or not 1 <= int(m.group(3)) <= 65535:
        raise NetsushisenError(f"--scheduler {address!r}: expected tcp://HOST:PORT (a Dask "
                               "scheduler's address, port 1..65535)")


# -- the cluster --------------------------------------------------------------------------------

def connect(scheduler: str | None, workers: int | None):
    """(client, cluster): a client of the scheduler at `scheduler`, else of a new LocalCluster
    of `workers` single-threaded processes (cluster None when it is not ours to close)."""
    from dask.distributed import Client, LocalCluster
    if scheduler:
        greeting(scheduler)
        try:
            return Client(scheduler, timeout="10s"), None
        except Exception as err:  # noqa: BLE001
            # whatever Dask's reader raises on a server that breaks its protocol after a
            # plausible greeting (MemoryError: its reply read as a frame length; struct.error:
            # half a frame; msgpack's errors: bytes that do not decode) is this one line
            raise NetsushisenError(f"--scheduler {scheduler}: cannot connect "
                                   f"({type(err).__name__}: {str(err)[:200]})") from None
    n = workers or os.cpu_count() or 1
    # the workers ignore SIGINT (inherited; Python keeps an ignored SIGINT ignored): Ctrl-C at
    # a terminal reaches the whole process group, and only this process should answer it
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        with warnings.catch_warnings():
            # its scheduler's HTTP endpoint (health, no dashboard) warns when another cluster on
            # this machine holds the default port 8787, then takes another: not the user's concern
            warnings.filterwarnings("ignore", message="Port .* is already in use")
            # its logs at CRITICAL only: a task's error reaches the command through its future,
            # and after a Ctrl-C a worker whose scheduler has just closed logs a failed heartbeat
            # with a traceback (at ERROR) on the shared terminal
            cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=not IN_PROCESS,
                                   dashboard_address=None, silence_logs=logging.CRITICAL)
    finally:
        signal.signal(signal.SIGINT, previous)
    return Client(cluster), cluster


GREETING_SECONDS = 10.0
"""How long a scheduler may take to send its greeting (Client's own connect timeout)."""
MAX_GREETING = 1 << 20
"""A Dask greeting (its handshake) is a few hundred bytes: a first frame announced larger than
this is not one."""


def greeting(address: str) -> None:
    """Check, before Dask reads anything, that a Dask scheduler answers at `address`: it sends
    its handshake as soon as a connection opens, an 8-byte little-endian length first. Anything
    else (an HTTP server, garbage, silence, a closed port) is one line here, where Dask's own
    reader would take the first 8 bytes of "HTTP/1.1" for a frame length and try to allocate it.
    tls:// addresses are left to Dask (their bytes are encrypted)."""
    import socket
    import struct

    m = _ADDRESS.match(address)
    if m is None or m.group(1) != "tcp":
        return
    host, port = m.group(2).strip("[]"), int(m.group(3))

    def refuse(why: str) -> NetsushisenError:
        return NetsushisenError(f"--scheduler {address}: cannot connect ({why})")

    try:
        with socket.create_connection((host, port), timeout=GREETING_SECONDS) as sock:
            first = b""
            while len(first) < 8:
                chunk = sock.recv(8 - len(first))
                if not chunk:
                    raise refuse("the server closed the connection without a Dask greeting")
                first += chunk
    except TimeoutError:
        raise refuse(f"no Dask greeting within {GREETING_SECONDS:g} s: not a Dask scheduler?") from None
    except OSError as err:
        raise refuse(err.strerror or type(err).__name__) from None
    except (UnicodeError, ValueError) as err:  # a host name no resolver takes (a label over 63)
        raise refuse(f"not a host name: {err}") from None
    (size,) = struct.unpack("<Q", first)
    if size > MAX_GREETING:
        shown = first.decode("ascii", "replace")
        shown = "".join(c if c.isprintable() else "?" for c in shown)
        raise refuse(f"not a Dask scheduler: it answered {shown!r}")


@dataclass(frozen=True)
class Task:
    """One independent run: `fn(*args)` in a worker (module-level, picklable). With `emits`,
    `fn` also takes `emit=`, a callable that sends a finished part to the command at once."""

    fn: Callable
    args: tuple
    label: str
    emits: bool = False


@dataclass
class Outcome:
    """How a batch ended: indexes done (their results went to `on_done`) and whether Ctrl-C
    stopped it."""

    done: set[int] = field(default_factory=set)
    interrupted: bool = False


def _call(fn: Callable, args: tuple, queue: str | None, index: int):
    """In the worker: the task, its emitted parts tagged with its index."""
    if queue is None:
        return fn(*args)
    from dask.distributed import Queue
    q = Queue(queue)
    return fn(*args, emit=lambda item: q.put((index, item)))


REFETCHES = 3
"""Times a task whose result could not be fetched, though the task itself did not fail (its
worker died after it finished), is run again before it counts as lost."""


def run_tasks(tasks: list[Task], on_done: Callable[[int, Any], None], *,
              scheduler: str | None = None, workers: int | None = None, title: str = "runs",
              show: bool = False, on_item: Callable[[int, Any], None] | None = None,
              on_error: Callable[[int, BaseException], None] | None = None,
              status: Callable[[], str] | None = None, done_before: int = 0) -> Outcome:
    """Run `tasks` on the cluster (see the module docstring). `on_done(index, result)` for each
    as it finishes; `on_item(index, item)` for what a task emits before; a task's exception goes
    to `on_error(index, error)`, or is raised here when there is none. `status()`: the bar's
    text; `done_before`: runs already done (a cache's), counted on the bar."""
    outcome = Outcome()
    if not tasks:
        return outcome
    client = cluster = None
    bar = _Bar(title, len(tasks) + done_before, done_before) if show and sys.stderr.isatty() else None
    queue = None
    futures: list = []
    index: dict = {}
    try:
        client, cluster = connect(scheduler, workers or min(os.cpu_count() or 1, len(tasks)))
        from dask.distributed import Queue, as_completed
        name = None
        if on_item is not None and any(t.emits for t in tasks):
            name = f"netsushisen-{uuid.uuid4().hex}"
            queue = Queue(name, client=client)
        for i, t in enumerate(tasks):
            f = client.submit(_call, t.fn, t.args, name if t.emits else None, i,
                              key=f"{t.label}-{uuid.uuid4().hex[:8]}", pure=False)
            index[f.key] = i
            futures.append(f)
        pending = as_completed(futures)
        refetched = [0] * len(tasks)
        while not pending.is_empty():
            _drain(queue, on_item)
            for fut in pending.next_batch(block=False):
                i = index[fut.key]
                _drain(queue, on_item)  # its parts before its result
                try:
                    result = fut.result()
                except Exception as err:  # noqa: BLE001 (a worker lost too often, or the task's own)
                    t = tasks[i]
                    if fut.status != "error" and not t.emits and refetched[i] < REFETCHES:
                        # not the task's own error: it finished, then the worker holding its
                        # result died before the fetch (distributed may then fail the fetch
                        # itself, "bound to a different event loop"); run it again
                        refetched[i] += 1
                        again = client.submit(_call, t.fn, t.args, None, i, pure=False,
                                              key=f"{t.label}-{uuid.uuid4().hex[:8]}")
                        index[again.key] = i
                        futures.append(again)
                        pending.add(again)
                        continue
                    if on_error is None:
                        raise
                    on_error(i, err)
                else:
                    on_done(i, result)
                outcome.done.add(i)
                if bar is not None:
                    bar.update(len(outcome.done) + done_before, status() if status else "")
            time.sleep(POLL)
        _drain(queue, on_item)
    except KeyboardInterrupt:
        outcome.interrupted = True
        try:
            _drain(queue, on_item)  # what was emitted before the Ctrl-C is kept
            for f in futures:  # and every result that had arrived
                if index[f.key] not in outcome.done and f.status == "finished":
                    on_done(index[f.key], f.result())
                    outcome.done.add(index[f.key])
        except Exception:  # noqa: BLE001 (the scheduler may be gone: nothing more to keep)
            pass
    finally:
        if bar is not None:
            bar.stop()
        if client is not None:
            client.close()
        if cluster is not None:
            cluster.close()
    return outcome


def _drain(queue, on_item) -> None:
    if queue is None:
        return
    if queue.qsize():
        for index, item in queue.get(batch=True):
            on_item(index, item)


class _Bar:
    """One rich progress bar on standard error: tasks done of all, the command's status text."""

    def __init__(self, title: str, total: int, done: int) -> None:
        from rich.console import Console
        from rich.progress import (BarColumn, MofNCompleteColumn, Progress, TextColumn,
                                   TimeRemainingColumn)
        self.p = Progress(TextColumn(title), BarColumn(), MofNCompleteColumn(),
                          TextColumn("{task.description}"), TimeRemainingColumn(),
                          console=Console(stderr=True), transient=True)
        self.p.start()
        self.task = self.p.add_task("", total=total, completed=done)

    def update(self, done: int, text: str) -> None:
        self.p.update(self.task, completed=done, description=text)

    def stop(self) -> None:
        self.p.stop()


# -- the result cache ---------------------------------------------------------------------------

class ResultCache:
    """Finished results as `FOLDER/KEY.json`, each with a checksum of its content and a stamp
    (e.g. the hash of the spec that wrote it). `load` returns the result, None when there is no
    file, or a sentence saying what is wrong with it (then it is computed again)."""

    def __init__(self, folder: Path) -> None:
        self.folder = folder
        folder.mkdir(parents=True, exist_ok=True)

    def path(self, key: str) -> Path:
        return self.folder / f"{key}.json"

    def has(self, key: str) -> bool:
        return self.path(key).exists()

    def store(self, result: dict, stamp: str = "") -> None:
        """Atomically (a killed run leaves whole files only); `result["key"]` names it."""
        result = json.loads(json.dumps(result, default=str))  # as it will read back
        result["spec"] = stamp
        result["checksum"] = checksum(result)
        write_text(self.path(result["key"]), json.dumps(result))

    def load(self, key: str) -> dict | str | None:
        if not self.has(key):
            return None
        try:
            result = json.loads(self.path(key).read_text(encoding="utf-8"))
        except (OSError, UnicodeDecodeError, ValueError, RecursionError):
            return "is not whole JSON (truncated?)"
        if not isinstance(result, dict) or "checksum" not in result:
            return "has no checksum"
        if result["checksum"] != checksum(result):
            return "does not match its checksum (edited or damaged)"
        if result.get("key") != key:
            return "was written for another run"
        return result


def checksum(result: dict) -> str:
    body = {k: v for k, v in result.items() if k != "checksum"}
    return hashlib.sha256(json.dumps(body, sort_keys=True, default=str).encode()).hexdigest()


def content_key(*parts: object) -> str:
    """The key of a run: a hash of everything its result is a function of (the project's version
    among them), each part as text."""
    from netsushisen import __version__
    h = hashlib.sha256()
    for part in (*parts, __version__):
        h.update(str(part).encode() + b"\0")
    return h.hexdigest()[:20]


def kernel_digest() -> str:
    """The hash of the kernel sources (every .s and .inc under kernels/, by name)."""
    from netsushisen.kernels import KERNELS
    h = hashlib.sha256()
    for p in sorted(Path(KERNELS).rglob("*")):
        if p.is_file() and p.suffix in (".s", ".inc"):
            h.update(p.name.encode() + b"\0" + p.read_bytes())
    return h.hexdigest()


def scene_digest(scene) -> str:
    """The hash of a scene's NFF text (a built-in scene's as generated; `scene`: a name or file
    for `load_scene`, or a Scene)."""
    from netsushisen.host.catalog import load_scene
    from netsushisen.host.nff import format_nff
    return hashlib.sha256(format_nff(load_scene(scene) if isinstance(scene, str) else scene)
                          .encode()).hexdigest()


def plain(obj: Any) -> Any:
    """`obj` as JSON values, losslessly for what runs return: dataclasses as dicts of their
    fields, numpy arrays as {"__ndarray__": dtype, "data": [...]}, numpy scalars as Python
    numbers (floats keep inf and nan: Python's JSON writes and reads them)."""
    import dataclasses

    import numpy as np
    if dataclasses.is_dataclass(obj) and not isinstance(obj, type):
        return {f.name: plain(getattr(obj, f.name)) for f in dataclasses.fields(obj)}
    if isinstance(obj, np.ndarray):
        return {"__ndarray__": obj.dtype.str, "shape": list(obj.shape), "data": obj.ravel().tolist()}
    if isinstance(obj, np.generic):
        return obj.item()
    if isinstance(obj, dict):
        return {str(k): plain(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [plain(v) for v in obj]
    return obj


def unplain(obj: Any) -> Any:
    """The arrays of `plain` back (dataclasses stay dicts: their owner rebuilds them)."""
    import numpy as np
    if isinstance(obj, dict):
        if "__ndarray__" in obj:
            return np.asarray(obj["data"], dtype=np.dtype(obj["__ndarray__"])).reshape(obj["shape"])
        return {k: unplain(v) for k, v in obj.items()}
    if isinstance(obj, list):
        return [unplain(v) for v in obj]
    return obj


def run_cached(tasks: list[Task], keys: list[str], cache: ResultCache | None,
               on_done: Callable[[int, Any], None], *,
               decode: Callable[[int, Any], Any] = lambda i, x: unplain(x),
               fresh: bool = False, on_item: Callable[[int, Any], None] | None = None,
               on_error: Callable[[int, BaseException], None] | None = None,
               **options) -> tuple[Outcome, int]:
    """`run_tasks` through `cache` (None: no cache): a task whose key has a whole result there
    is not run, its result (`decode(index, plain form)`) goes to `on_done` at once; every computed
    result is stored the moment it arrives. `fresh`: compute everything again. (outcome, the
    number of results taken from the cache); indexes are the caller's throughout."""
    todo: list[int] = []
    cached = 0
    for i, key in enumerate(keys):
        found = cache.load(key) if cache is not None and not fresh else None
        if isinstance(found, str):
            print(f"{tasks[i].label}: {cache.path(key)} {found}: computing it again", file=sys.stderr)
        elif found is not None:
            on_done(i, decode(i, found["result"]))
            cached += 1
            continue
        todo.append(i)

    def done(j: int, result: Any) -> None:
        i = todo[j]
        if cache is not None:
            cache.store({"key": keys[i], "result": plain(result)})
        on_done(i, result)

    outcome = run_tasks([tasks[i] for i in todo], done, done_before=cached,
                        on_item=None if on_item is None else (lambda j, x: on_item(todo[j], x)),
                        on_error=None if on_error is None else (lambda j, e: on_error(todo[j], e)),
                        **options)
    outcome.done = {todo[j] for j in outcome.done} | (set(range(len(keys))) - set(todo))
    return outcome, cached
