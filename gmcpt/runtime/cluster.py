"""Ray, only when asked for (``--ray ADDRESS``): connect, run one task per job, disconnect.

``local`` starts a Ray cluster of this machine from the driver (and stops it
afterwards); ``auto``, ``HOST:PORT`` or ``ray://HOST:PORT`` join a running
one (``ray start --head`` on the head node, ``ray start --address HEAD:6379``
on the others). Every node needs this gmcpt installed; the driver also puts
its own copy's folder on the workers' ``PYTHONPATH``, which a node that
shares the file system (and a local cluster) then imports.

Tasks declare their resources (CPUs, GPUs) and are retried ``max_retries``
times when their worker dies (a crash, a lost node); an exception a task
raises is not retried and reaches the driver as itself. Nothing here imports
Ray at module level: commands without ``--ray`` never load it.
"""
from __future__ import annotations

import contextlib
import logging
import os
import re
import sys
from pathlib import Path
from typing import Callable, Iterable, Iterator

from ..errors import GmcptError

LOCAL = "local"
AUTH_LOGGER = "ray._private.authentication.authentication_token_setup"
_ADDRESS = re.compile(r"^(auto|(ray://)?[A-Za-z0-9_.\-\[\]:]+:\d{1,5})$")


def check_address(address: str) -> str:
    """``address`` if it names a Ray cluster (``local``, ``auto``, ``HOST:PORT``, ``ray://HOST:PORT``)."""
    if address == LOCAL or _ADDRESS.match(address or ""):
        return address
    raise GmcptError(f"--ray expects local, auto, HOST:PORT or ray://HOST:PORT, got {address!r}")


def host_port(address: str) -> tuple[str, int] | None:
    """(host, port) of a ``HOST:PORT`` or ``ray://HOST:PORT`` address; None for ``local`` and ``auto``."""
    if address in (LOCAL, "auto"):
        return None
    host, _, port = address.removeprefix("ray://").rpartition(":")
    return host.strip("[]"), int(port)


def check_reachable(address: str, timeout: float = 10.0) -> None:
    """Fail in one line if nothing listens at ``address`` (ray.init would retry for ever)."""
    import socket

    target = host_port(address)
    if target is None:
        return
    try:
        socket.create_connection(target, timeout=timeout).close()
    except OSError as error:
        raise GmcptError(f"cannot reach the Ray cluster at {address}: {error.strerror or error}") from None


def _package_path() -> str:
    return str(Path(__file__).resolve().parents[2])  # the folder holding gmcpt/


@contextlib.contextmanager
def _quiet_auth_notice():
    """Ray's notice that token authentication is on (its default for a cluster it starts) is left unsaid:
    nothing is asked of the user, and authentication stays as Ray sets it."""
    auth_log = logging.getLogger(AUTH_LOGGER)
    level = auth_log.level
    auth_log.setLevel(logging.ERROR)
    try:
        yield
    finally:
        auth_log.setLevel(level)


@contextlib.contextmanager
def connected(address: str, quiet: bool = False):
    """Connect to (``local``: start) the Ray cluster at ``address`` for the ``with`` block.

    Yields the cluster's total resources (``{"CPU": 2.0, ...}``). Ray's own messages (a worker
    died, a task runs again) go to stderr meanwhile: stdout stays the command's result.
    """
    check_address(address)
    check_reachable(address)
    try:
        import ray
    except ImportError:
        raise GmcptError("--ray needs Ray: pip install 'gmcpt[ray]' (or pip install ray)") from None
    path = os.pathsep.join(filter(None, [_package_path(), os.environ.get("PYTHONPATH")]))
    options = {"runtime_env": {"env_vars": {"PYTHONPATH": path}}, "log_to_driver": not quiet,
               "logging_level": logging.ERROR, "configure_logging": quiet}
    with contextlib.redirect_stdout(sys.stderr), _quiet_auth_notice():
        try:
            if address == LOCAL:
                ray.init(include_dashboard=False, **options)
            else:
                ray.init(address=address, **options)
        except (ConnectionError, RuntimeError, ValueError) as error:
            raise GmcptError(f"cannot reach the Ray cluster at {address}: {' '.join(str(error).split())}") from None
        try:
            yield dict(ray.cluster_resources())
        finally:
            ray.shutdown()


def default_gpus(resources: dict) -> float:
    """GPUs a task asks for when not told: 1 where the cluster has any, else 0."""
    return 1.0 if resources.get("GPU", 0) >= 1 else 0.0


def run_tasks(function: Callable, jobs: Iterable, cpus: float = 1, gpus: float = 0,
              max_retries: int = 3) -> Iterator:
    """``function(job)`` as one Ray task per job; yields the results in the order they finish.

    Needs :func:`connected`. A task whose worker process dies is run again, up to
    ``max_retries`` times; an exception it raises reaches the caller as itself.
    """
    import ray
    from ray.exceptions import RayTaskError

    remote = ray.remote(function).options(num_cpus=cpus, num_gpus=gpus, max_retries=max_retries,
                                          retry_exceptions=False)
    pending = [remote.remote(job) for job in jobs]
    try:
        while pending:
            done, pending = ray.wait(pending, num_returns=1)
            try:
                yield ray.get(done[0])
            except RayTaskError as error:
                cause = getattr(error, "cause", None)
                raise (cause if isinstance(cause, BaseException) else error) from None
    finally:
        for ref in pending:  # an error or an interrupt: do not leave work running
            ray.cancel(ref, force=True)
