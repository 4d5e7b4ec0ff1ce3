"""Where a sweep runs: a Dask ``LocalCluster`` on this machine, or an existing scheduler.

:func:`connect` gives a ``distributed.Client``:

* no address (and no ``DASK_SCHEDULER_ADDRESS``): a ``LocalCluster`` of worker processes
  (one thread each; by default one per core available to this process), its scheduler
  and workers on 127.0.0.1 and no dashboard, so a sweep opens no port beyond the
  loopback interface;
* an address (``--scheduler tcp://host:8786`` or ``DASK_SCHEDULER_ADDRESS``): that
  scheduler and its workers (a dask-jobqueue or Kubernetes cluster: ``docs/sweep.md``).
  An address that does not answer within :data:`CONNECT_TIMEOUT_S` is an InputError
  naming it.

Fault tolerance is Dask's own: a task whose worker dies is rescheduled on another worker,
and after :data:`ALLOWED_FAILURES` + 1 deaths the scheduler gives up on it
(``KilledWorker``); an exception inside a task is retried once (``retries`` of
``Client.submit``). The local cluster's scheduler gets ``allowed-failures`` from here; an
external scheduler's own configuration applies (set
``DASK_DISTRIBUTED__SCHEDULER__ALLOWED_FAILURES=1`` where it starts).
"""

from __future__ import annotations

import contextlib
import logging
import os
import sys
import time

from isodesign.errors import InputError

__all__ = ["ALLOWED_FAILURES", "CONNECT_TIMEOUT_S", "LOCAL_CONFIG", "PROBE_TIMEOUT_S", "Connection",
           "connect", "probe_scheduler"]

#: Seconds to wait for an external scheduler before giving up.
CONNECT_TIMEOUT_S = 5.0
#: Address schemes of Dask's communication layers.
DASK_SCHEMES = ("tcp", "tls", "ws", "wss", "ucx", "inproc")
#: Seconds the probe (:func:`probe_scheduler`) waits for a Dask handshake: an address that
#: answers but is not a Dask scheduler ends in one line within it.
PROBE_TIMEOUT_S = 3.0
#: Worker deaths a task survives (the next one marks it failed: it failed twice).
ALLOWED_FAILURES = 1
#: Dask configuration of the local cluster. A sweep task is seconds of single-threaded,
#: GIL-holding optimization; on a machine whose cores all run tasks, every cycle that
#: Dask's own monitoring takes is a cycle a point waits for (measured in
#: ``benchmarks/bench_sweep.py``). So, against Dask's defaults (which suit many short,
#: data-heavy tasks):
#:
#: * ``allowed-failures``: a task survives one worker death (see the module docstring);
#: * ``MALLOC_TRIM_THRESHOLD_`` is not set in the workers (Dask sets 64 KiB to give the
#:   memory of large arrays back to the OS): glibc's own threshold, so that CasADi and
#:   IPOPT, which free and allocate again many medium blocks per point, do not pay a page
#:   fault for each (with 64 KiB a point takes measurably more CPU time);
#: * no statistical profiler in the workers (it samples the task's stack every 10 ms,
#:   interrupting it; its profile feeds only the dashboard, which is off);
#: * the event-loop health tick, the memory monitor and the system monitor every 1, 1 and
#:   2 s instead of 20 ms, 100 ms and 0.5 s (the memory limit still holds: the nanny
#:   restarts a worker that exceeds it, and its task is retried);
#: * one task per worker thread at a time (``worker-saturation`` 1.0) and no work
#:   stealing: a worker asks for its next point when it is free, so no point waits in the
#:   queue of a busy worker while another worker idles at the end of the sweep.
LOCAL_CONFIG = {
    "distributed.scheduler.allowed-failures": ALLOWED_FAILURES,
    "distributed.scheduler.worker-saturation": 1.0,
    "distributed.scheduler.work-stealing": False,
    "distributed.nanny.pre-spawn-environ.MALLOC_TRIM_THRESHOLD_": None,
    "distributed.worker.daemon": True,
    "distributed.worker.profile.enabled": False,
    "distributed.worker.memory.monitor-interval": "1s",
    "distributed.admin.tick.interval": "1s",
    "distributed.admin.system-monitor.interval": "2s",
    "distributed.admin.system-monitor.gil.enabled": False,
}


class Connection:
    """A Dask client and, for a local cluster, the cluster it owns (closed together).

    Attributes
    ----------
    client : distributed.Client
    cluster : distributed.LocalCluster or None
    where : str
        For messages: ``local cluster (2 workers on 127.0.0.1)`` or the address.
    workers : int
        Workers at connection time.
    """

    def __init__(self, client, cluster, where: str, workers: int):
        self.client, self.cluster, self.where, self.workers = client, cluster, where, workers

    def close(self) -> None:
        """Close the client and the local cluster (its worker processes end)."""
        with contextlib.suppress(Exception):
            self.client.close(timeout=5)
        if self.cluster is not None:
            with contextlib.suppress(Exception):
                self.cluster.close(timeout=10)

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()
        return False


def _ignore_sigint_plugin():
    """A worker plugin: the local cluster's workers ignore SIGINT (Ctrl-C reaches the whole
    process group; the sweep cancels their tasks and closes the cluster itself)."""
    from distributed.diagnostics.plugin import WorkerPlugin

    class IgnoreSigint(WorkerPlugin):
        name = "isodesign-ignore-sigint"

        def setup(self, worker):
            import signal
            import threading

            if threading.current_thread() is threading.main_thread():
                signal.signal(signal.SIGINT, signal.SIG_IGN)

    return IgnoreSigint()


@contextlib.contextmanager
def _environ_kept():
    """Undo, in this process, the variables a nanny sets before it spawns its worker
    (``OMP_NUM_THREADS=1`` ...): they are meant for the worker processes, not for the
    process that runs the sweep and whatever it starts afterwards."""
    saved = dict(os.environ)
    try:
        yield
    finally:
        for k in [k for k in os.environ if k not in saved]:
            del os.environ[k]
        for k, v in saved.items():
            if os.environ.get(k) != v:
                os.environ[k] = v


def _quiet_logs() -> None:
    for name in ("distributed", "distributed.comm", "distributed.core", "distributed.nanny",
                 "distributed.scheduler", "distributed.worker", "tornado"):
        logging.getLogger(name).setLevel(logging.CRITICAL)


def connect(scheduler: str | None = None, workers: int | None = None, *,
            option: str = "--scheduler", timeout_s: float = CONNECT_TIMEOUT_S,
            config: dict | None = None) -> Connection:
    """A Dask client: a local cluster, or the scheduler at ``scheduler``.

    Parameters
    ----------
    scheduler : str, optional
        ``tcp://host:port`` (or ``host:port``); default ``DASK_SCHEDULER_ADDRESS``, else a
        ``LocalCluster``.
    workers : int, optional
        Worker processes of a local cluster (default: the cores available to this
        process); ignored for an external scheduler.
    option : str
        For messages.
    timeout_s : float
        Connection timeout for an external scheduler.
    config : dict, optional
        Dask configuration of a local cluster (default :data:`LOCAL_CONFIG`; the
        benchmark compares it with Dask's defaults).

    Returns
    -------
    Connection
    """
    import dask
    from distributed import Client, LocalCluster

    from isodesign.optimization.multistart import available_cores

    _quiet_logs()
    address = scheduler or os.environ.get("DASK_SCHEDULER_ADDRESS") or None
    if address:
        if address == "local":
            address = None
        elif any(c.isspace() for c in address) or not address.strip(":/"):
            raise InputError(f"{option}: {address!r} is not a scheduler address "
                             "(tcp://host:port)")
    if workers is not None and (isinstance(workers, bool) or not isinstance(workers, int)
                                or not 1 <= workers <= 64):
        raise InputError(f"--workers: must be an integer in [1, 64], got {workers!r:.40}")
    if address:
        src = option if scheduler else "DASK_SCHEDULER_ADDRESS"
        t0 = time.monotonic()
        probe_scheduler(address, src, timeout_s=min(timeout_s, PROBE_TIMEOUT_S))
        left = max(timeout_s - (time.monotonic() - t0), 1.0)
        try:
            client = Client(address, timeout=f"{left}s", set_as_default=False)
        except Exception as exc:  # whatever the peer did: one line
            raise InputError(
                f"{src}: cannot reach the Dask scheduler at {address} within {timeout_s:g} s "
                f"({type(exc).__name__}: {' '.join(str(exc).split())[:160]}); start it "
                "(dask scheduler), check the address, or leave --scheduler out for a "
                "local cluster") from None
        n = len(client.scheduler_info(n_workers=-1).get("workers", {})) \
            if _accepts_n_workers(client) else len(client.scheduler_info().get("workers", {}))
        return Connection(client, None, f"scheduler {address} ({n} workers now)", n)
    n = int(workers) if workers else available_cores()
    conn = None
    try:
        # a Ctrl-C while the cluster starts waits until it has started (a half-started
        # cluster prints its threads' and processes' tracebacks), then ends it cleanly
        with _sigint_deferred(), _children_stderr_quiet():
            with dask.config.set(LOCAL_CONFIG if config is None else config), \
                    _environ_kept():
                # no dashboard; the scheduler's HTTP routes on a free loopback port
                cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=True,
                                       host="127.0.0.1", dashboard_address="127.0.0.1:0",
                                       scheduler_kwargs={"dashboard": False},
                                       worker_dashboard_address=None,
                                       silence_logs=logging.CRITICAL, scheduler_port=0)
            client = Client(cluster, set_as_default=False)
            conn = Connection(client, cluster,
                              f"local cluster ({n} worker processes on 127.0.0.1)", n)
            with contextlib.suppress(Exception):  # best effort: a worker's traceback is cosmetic
                client.register_plugin(_ignore_sigint_plugin())
    except BaseException:
        if conn is not None:
            conn.close()
        raise
    return conn


@contextlib.contextmanager
def _children_stderr_quiet():
    """The worker processes started meanwhile write their stderr to /dev/null.

    They inherit file descriptor 2 when they are spawned; their logs are silenced anyway,
    and a Ctrl-C that reaches the whole process group while they import would print each
    one's traceback (dozens of lines) under the sweep's one line. This process's own
    stderr is restored on exit (it writes nothing while the cluster starts).
    """
    import threading

    if threading.current_thread() is not threading.main_thread():
        yield
        return
    try:
        sys.stderr.flush()
        saved = os.dup(2)
        quiet = os.open(os.devnull, os.O_WRONLY)
    except (OSError, ValueError, AttributeError):
        yield
        return
    try:
        os.dup2(quiet, 2)
        yield
    finally:
        os.dup2(saved, 2)
        os.close(saved)
        os.close(quiet)


@contextlib.contextmanager
def _sigint_deferred():
    """SIGINT held back in this thread (and the threads and processes started meanwhile,
    which inherit the mask: the cluster's workers never see a Ctrl-C); delivered on exit."""
    import signal
    import threading

    if threading.current_thread() is not threading.main_thread() \
            or not hasattr(signal, "pthread_sigmask"):
        yield
        return
    old = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, old)


def _host_port(address: str, src: str) -> tuple[str, int] | None:
    """``(host, port)`` of a ``tcp://`` (or scheme-less) address; None for other schemes."""
    rest = address
    if "://" in address:
        scheme, rest = address.split("://", 1)
        if scheme not in DASK_SCHEMES:
            raise InputError(f"{src}: {address!r} is not a Dask scheduler address (scheme "
                             f"{scheme!r}; Dask's: {', '.join(DASK_SCHEMES)}, e.g. "
                             "tcp://host:8786)")
        if scheme != "tcp":
            return None  # tls://, ucx://, ws://: the client's own handshake judges them
    rest = rest.rstrip("/")
    if rest.startswith("["):  # [::1]:8786
        host, _, port = rest[1:].partition("]")
        port = port.removeprefix(":")
    else:
        host, _, port = rest.rpartition(":")
    if not host or not port.isdigit() or not 0 < int(port) < 65536:
        raise InputError(f"{src}: {address!r} is not a scheduler address (tcp://host:port, "
                         "port 1-65535)")
    return host, int(port)


def probe_scheduler(address: str, src: str = "--scheduler",
                    timeout_s: float = PROBE_TIMEOUT_S) -> None:
    """Check that ``address`` is a Dask scheduler before handing it to ``Client``.

    A Dask server sends its handshake (an 8-byte frame length, then a small msgpack
    message with ``compression`` and ``python``) as soon as it accepts a connection. Anything
    else (an HTTP server that waits for a request, a port that sends garbage, whose first
    8 bytes the client would take for a frame size of exabytes) is refused in one line
    within ``timeout_s``.

    Parameters
    ----------
    address : str
        ``tcp://host:port`` or ``host:port``.
    src : str
        The option or variable that gave it, for messages.
    timeout_s : float
        Seconds for the connection and the handshake together.

    Raises
    ------
    InputError
        Not reachable, or not a Dask scheduler.
    """
    import socket
    import struct

    hp = _host_port(address, src)
    if hp is None:
        return
    deadline = time.monotonic() + timeout_s
    hint = ("start it (dask scheduler), check the address, or leave --scheduler out for a "
            "local cluster")
    try:
        sock = socket.create_connection(hp, timeout=timeout_s)
    except OSError as exc:
        raise InputError(f"{src}: cannot reach the Dask scheduler at {address} within "
                         f"{timeout_s:g} s ({type(exc).__name__}: "
                         f"{' '.join(str(exc).split())[:120]}); {hint}") from None
    not_dask = f"{src}: {address} answers but is not a Dask scheduler"
    try:
        def read(n: int) -> bytes:
            buf = b""
            while len(buf) < n:
                left = deadline - time.monotonic()
                if left <= 0:
                    raise TimeoutError
                sock.settimeout(left)
                chunk = sock.recv(n - len(buf))
                if not chunk:
                    raise ConnectionError("closed")
                buf += chunk
            return buf

        try:
            (size,) = struct.unpack("<Q", read(8))
            if not 0 < size <= 1 << 16:
                raise InputError(f"{not_dask} (its first bytes are no Dask handshake); {hint}")
            body = read(size)
        except TimeoutError:
            raise InputError(f"{not_dask} (no Dask handshake within {timeout_s:g} s: an HTTP "
                             f"or other server?); {hint}") from None
        except OSError as exc:
            raise InputError(f"{not_dask} (the connection ended during the handshake: "
                             f"{type(exc).__name__}); {hint}") from None
        if b"compression" not in body or b"python" not in body:
            raise InputError(f"{not_dask} (its handshake is not Dask's); {hint}")
    finally:
        with contextlib.suppress(OSError):
            sock.close()


def _accepts_n_workers(client) -> bool:
    import inspect

    return "n_workers" in inspect.signature(client.scheduler_info).parameters
