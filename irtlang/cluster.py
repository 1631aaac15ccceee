"""Runs that outgrow one machine: trace batches on a Dask cluster, with bitwise the same answer.

``irt run FILE --scheduler tcp://host:8786`` (or ``--workers N`` for a cluster of N local processes) hands
each TRACE's ray batches to Dask workers instead of tracing them here.  Nothing else changes:

* The packed scene (irtlang.compile.pack.Packed, a dataclass of numpy arrays) is scattered to the workers
  once per trace; a work unit is (scene future, scene key, trace options, first ray id, count), a few hundred
  bytes.  Each worker process builds a TraceContext once per scene key (the specialized kernel comes from
  the Numba cache in $NUMBA_CACHE_DIR) and keeps the last few.
* A worker returns the batch's raw chunk tallies (BatchTally); the client reduces them in ray-id order
  (irtlang.tracer.Accumulator).  Ray paths depend only on (seed, ray id, event) (counter-based Philox) and the
  reduction order is fixed, so the ledger, images and records are bitwise those of an in-process run, for
  any number of workers, any placement of units and any recomputation.
* At most ``per_worker`` units per worker are in flight; tallies are yielded in unit order as they arrive, so
  the client's memory stays flat and the progress line counts rays across all workers.
* A worker that dies takes its running and finished-but-unread units with it; the scheduler recomputes them
  elsewhere (the scene is broadcast to every worker, and scattered again if no copy survived).

Dask is an optional extra (``pip install "irtlang[cluster]"``); this module imports it only when used.
"""
from __future__ import annotations

import asyncio
import functools
import hashlib
import os
import pickle
import threading
import time
import uuid
import weakref
from collections import OrderedDict, deque
from concurrent.futures import CancelledError

import numpy as np

DEFAULT_TIMEOUT = 5.0
_CONTEXTS_KEPT = 3


class ClusterError(Exception):
    """A cluster problem the user can act on (unreachable scheduler, no workers, a unit that keeps failing)."""


def _need_distributed():
    try:
        import distributed
    except ImportError:
        raise ClusterError('--scheduler and --workers need Dask distributed: pip install "irtlang[cluster]" '
                           '(or pip install "dask[distributed]")') from None
    return distributed


def default_threads(workers: int) -> int:
    """Numba threads per worker for `workers` local worker processes sharing this machine's cores."""
    try:
        cores = len(os.sched_getaffinity(0))
    except AttributeError:  # pragma: no cover - not on Linux
        cores = os.cpu_count() or 1
    return max(1, cores // max(1, workers))


def connect(scheduler: str | None = None, workers: int | None = None, timeout: float = DEFAULT_TIMEOUT,
            threads: int | None = None):
    """A Dask client: to the scheduler at `scheduler`, or to a new local cluster of `workers` processes.

    A local cluster listens on the loopback only; each worker has one Dask thread and `threads` Numba threads
    (default: this machine's cores shared out).  ``close_client(client)`` also shuts a local cluster down.
    Raises ClusterError if the scheduler cannot be reached, or has no worker, within `timeout` seconds.
    """
    distributed = _need_distributed()
    if scheduler:
        try:
            from distributed.comm import parse_address
            from distributed.comm.registry import get_backend

            get_backend(parse_address(scheduler)[0])
        except (ValueError, TypeError) as e:
            raise ClusterError(f"{scheduler} is not a Dask scheduler address ({e})") from None
        try:
            client = distributed.Client(scheduler, timeout=timeout, set_as_default=False)
        except (OSError, TimeoutError, ValueError) as e:
            detail = "" if isinstance(e, (OSError, TimeoutError)) else f" ({e})"
            raise ClusterError(f"cannot reach the Dask scheduler at {scheduler} within {timeout:g} s{detail}") \
                from None
        try:
            client.wait_for_workers(1, timeout=timeout)
        except (OSError, TimeoutError):
            client.close()
            raise ClusterError(f"the Dask scheduler at {scheduler} has no workers (waited {timeout:g} s); "
                               f"start some with `dask worker {scheduler}`") from None
        return client
    n = 1 if workers is None else int(workers)
    if n < 1:
        raise ClusterError("--workers needs at least 1 worker")
    nth = threads or default_threads(n)
    import logging

    try:
        client = distributed.Client(n_workers=n, threads_per_worker=1, processes=True, host="127.0.0.1",
                                    dashboard_address="127.0.0.1:0", silence_logs=logging.ERROR, set_as_default=False,
                                    env={"NUMBA_NUM_THREADS": str(nth)}, timeout=max(timeout, 60.0))
        client.wait_for_workers(n, timeout=max(timeout, 60.0))
    except (OSError, TimeoutError) as e:
        raise ClusterError(f"could not start a local Dask cluster of {n} workers: {e}") from None
    return client


def close_client(client) -> None:
    """Close a client, and the local cluster it started.

    A LocalCluster follows its scheduler's workers in a background task (distributed's
    ``Cluster._watch_worker_status``).  When a killed worker's nanny starts a new one that leaves again before
    the cluster has listed it, that task dies with a KeyError on the unknown address
    (``SpecCluster._update_worker_status``, logged by distributed when it happens).  ``Client.close`` then
    re-raises it at the end of the cluster's close: the workers and the scheduler are stopped, but the cluster
    stays "closing", so a caller sees a traceback and any later close of it (a client's ``__del__``) waits 120 s
    for nothing.  The task only kept the cluster's own list of workers: a failed one is dropped before the close
    (tests/unit/test_cluster.py).  A scheduler given by address is not ours to stop: only the client closes."""
    cluster = getattr(client, "cluster", None)
    task = getattr(cluster, "_watch_worker_status_task", None)
    if task is not None and task.done() and not task.cancelled() and task.exception() is not None:
        cluster._watch_worker_status_task = None
    client.close()


def scene_key(pk) -> str:
    """A content hash of a packed scene (workers cache their TraceContext under it)."""
    return hashlib.sha256(pickle.dumps(pk, protocol=pickle.HIGHEST_PROTOCOL)).hexdigest()[:24]


# ------------------------------------------------------------------------------------------------ worker side
_contexts: OrderedDict = OrderedDict()
_lock = threading.Lock()   # one kernel call at a time per process (it already uses every Numba thread)


def _worker_context(pk, key: str, opts: tuple):
    from .tracer import TraceContext

    ck = (key, opts)
    ctx = _contexts.get(ck)
    if ctx is None:
        seed, level, halt, records, history = opts
        ctx = TraceContext(pk, seed=seed, level=level, halt=halt, records=records, history=history)
        _contexts[ck] = ctx
        while len(_contexts) > _CONTEXTS_KEPT:
            _contexts.popitem(last=False)
    else:
        _contexts.move_to_end(ck)
    return ctx


_units_traced = 0


class KernelMismatch(Exception):
    """A worker's irtlang kernels differ from the client's (another version): its rays would not be the same."""


@functools.lru_cache(maxsize=None)
def kernel_version() -> str:
    """irtlang's version and the hash of every kernel source a trace depends on."""
    from ._version import __version__
    from .compile.specialize import _sources_hash

    return f"{__version__}+{_sources_hash()}"


def trace_unit(pk, key: str, opts: tuple, first: int, n: int, version: str | None = None):
    """One work unit, run on a worker: trace ray ids first .. first + n - 1 and return their raw tallies."""
    global _units_traced
    if version is not None and version != kernel_version():
        import socket

        raise KernelMismatch(f"the worker on {socket.gethostname()} has irtlang {kernel_version()}, the client "
                             f"{version}: install the same irtlang on every worker")
    with _lock:
        t = _worker_context(pk, key, opts).run_batch(first, n)
        _units_traced += 1
    # send only the used part of each chunk's deposit list (the reduction reads dep_n[c] entries of row c)
    used = max(1, int(t.dep_n.max())) if len(t.dep_n) else 1
    if used < t.dep_idx.shape[1]:
        t.dep_idx = np.ascontiguousarray(t.dep_idx[:, :used])
        t.dep_w = np.ascontiguousarray(t.dep_w[:, :used])
        t.dep_d = np.ascontiguousarray(t.dep_d[:, :used])
    return t


def worker_units() -> int:
    """Work units this worker process has traced (``client.run(worker_units)`` shows the spread)."""
    return _units_traced


# ------------------------------------------------------------------------------------------------ client side
class DaskRunner:
    """``run_trace(..., runner=DaskRunner(client))``: trace the batches on the client's cluster.

    Yields the BatchTally of each unit in unit order, keeping at most `per_worker` units per worker in flight.
    """

    def __init__(self, client, *, per_worker: int = 3, retries: int = 3, timeout: float = 60.0):
        self.client = client
        self.timeout = timeout   # seconds to wait for a worker to send the scene to
        self.per_worker = max(1, int(per_worker))
        self.retries = retries
        self._scene = None   # (weakref to the TraceContext, scene key, scene future)
        self._nw = (0.0, 1)
        self.peak_in_flight = 0   # the most units in flight at once (bounded by per_worker x workers)

    # the scene goes to the workers once per trace (a second pass of TRACE UNTIL reuses it)
    def _scatter(self, ctx, again: bool = False):
        if self._scene is not None and self._scene[0]() is ctx and not again:
            return self._scene[1], self._scene[2]
        key = self._scene[1] if self._scene is not None and self._scene[0]() is ctx else scene_key(ctx.pk)
        self._scene = None   # release the previous scene's future (its copies leave the workers)
        for attempt in range(10):
            try:
                # a worker that died may still be starting again: broadcasting to no worker is an error
                self.client.wait_for_workers(1, timeout=self.timeout)
            except (OSError, TimeoutError) as e:
                raise ClusterError(f"no Dask worker to send the scene to within {self.timeout:g} s ({e})") from None
            try:
                fut = self.client.scatter(ctx.pk, broadcast=True, hash=False)
                break
            except (ValueError, OSError, KeyError) as e:
                # the last worker left between the two calls (no worker, or its stream closed under the
                # scatter), or a worker left while the scheduler broadcast to the list it had just taken (its
                # KeyError, seen when a cluster scaled down under load): wait and try again
                if attempt == 9:
                    raise ClusterError(f"the scene could not be sent to a Dask worker in 10 tries ({e})") from None
                time.sleep(0.2)
        self._scene = (weakref.ref(ctx), key, fut)
        return key, fut

    def _workers(self) -> int:
        t, n = self._nw
        now = time.monotonic()
        if now - t > 1.0:
            try:
                n = max(1, len(self.client.nthreads()))
            except Exception:  # noqa: BLE001 - a busy scheduler: keep the last count
                pass
            self._nw = (now, n)
        return n

    def __call__(self, ctx, units):
        return self._run(ctx, list(units))

    def _run(self, ctx, units):
        distributed = _need_distributed()
        client = self.client
        opts = (int(ctx.seed), int(ctx.level), float(ctx.halt), bool(ctx.records), bool(ctx.history))
        key, scene = self._scatter(ctx)
        version = kernel_version()
        pending: deque = deque()   # (unit index, future), in unit order
        nxt = 0

        def submit(i):
            f, n = units[i]
            return client.submit(trace_unit, scene, key, opts, f, n, version, pure=False,
                                 key=f"irt-batch-{f}-{n}-{uuid.uuid4().hex[:12]}")

        try:
            while pending or nxt < len(units):
                limit = self.per_worker * self._workers()
                while nxt < len(units) and len(pending) < limit:
                    pending.append((nxt, submit(nxt)))
                    nxt += 1
                self.peak_in_flight = max(self.peak_in_flight, len(pending))
                i, fut = pending.popleft()
                tries = 0
                while True:
                    try:
                        t = fut.result()
                        break
                    except KernelMismatch as e:
                        raise ClusterError(str(e)) from None
                    except (CancelledError, asyncio.CancelledError, distributed.KilledWorker, OSError,
                            TimeoutError) as e:
                        # the scene lost every copy (a one-worker cluster whose worker died) or the unit kept
                        # killing its workers: scatter the scene again and resubmit what is in flight
                        tries += 1
                        if tries > self.retries or client.status not in ("running", "connecting"):
                            raise ClusterError(f"trace batch of rays {units[i][0]}..{sum(units[i]) - 1} failed "
                                               f"on the Dask cluster: {type(e).__name__}: {e}") from None
                        key, scene = self._scatter(ctx, again=True)
                        fut = submit(i)
                        pending = deque((j, submit(j)) for j, _ in pending)
                del fut
                yield t
        finally:
            for _, f in pending:
                f.cancel()
