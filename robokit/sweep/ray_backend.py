"""The Ray backend: each trial is a Ray task that builds its own World on whichever node runs it.

What is shipped to a worker is a :class:`~robokit.sweep.trial.TrialTask`: the config's text, its folder, the
overrides, the seed, the run id and the names of extra plugin modules. No pybullet object ever crosses a process
boundary. robokit itself must be importable on every node (installed there, or shipped with a ``runtime_env``);
see ``docs/sweeps.md``.

Fault handling: a task whose worker process dies is retried once by Ray (``max_retries=1``) and then recorded as
an ``error``; a task that overruns ``trial_timeout`` is cancelled with ``force=True`` (its worker is killed) and
recorded as an ``error``. At most as many tasks as the cluster has CPUs are in flight, so a task's clock starts
close to when it really starts.
"""

from __future__ import annotations

import logging
import os
import socket
import time
from collections import deque
from collections.abc import Iterator, Sequence
from pathlib import Path
from typing import Any

from robokit.errors import UserError
from robokit.sweep.trial import TrialTask, error_row, run_trial_safely

MAX_CALLS = 100
"""Trials a Ray worker process runs before Ray replaces it (Ray's ``max_calls``)."""


def connect_error(address: str | None) -> str:
    """The one line for a Ray cluster that could not be joined: the address as typed (Ray's own message names
    the address the cluster advertises, which the user never typed) and the authentication hint. A head started
    where ``~/.ray/auth_token`` exists uses token authentication; a driver then needs ``RAY_AUTH_MODE=token``
    and the token, and without them Ray reports only that it cannot connect."""
    where = f"--address {address}" if address else "--backend ray"
    token = Path(os.environ.get("RAY_AUTH_TOKEN_PATH") or Path.home() / ".ray" / "auth_token")
    has_token = token.is_file() or bool(os.environ.get("RAY_AUTH_TOKEN"))
    if has_token and os.environ.get("RAY_AUTH_MODE", "").lower() != "token":
        hint = (f"a Ray token exists ({'RAY_AUTH_TOKEN' if not token.is_file() else token}) but RAY_AUTH_MODE "
                "is not 'token': if the cluster uses token authentication, run again with RAY_AUTH_MODE=token")
    elif has_token:
        hint = "check that the cluster is running (ray status) and that this token is the cluster's"
    else:
        hint = ("check that the cluster is running (ray status); if it uses token authentication, copy its token "
                "to ~/.ray/auth_token and run with RAY_AUTH_MODE=token")
    return f"{where}: cannot connect to a Ray cluster there (none answered, or it refused this driver): {hint}"


def _probe(address: str | None) -> None:
    """Fail at once when nothing listens at a ``HOST:PORT`` address: Ray retries such an address without end (a
    mistyped port hung the sweep). ``auto``, ``ray://`` and other forms are left to Ray."""
    host, _, port = (address or "").rpartition(":")
    if not host or not port.isdigit() or "/" in host:
        return
    try:
        with socket.create_connection((host.strip("[]"), int(port)), timeout=10):
            pass
    except OSError as exc:
        raise UserError(f"--address {address}: nothing answers there ({exc.strerror or exc}); is the cluster "
                        "running (ray status on its head) and is that its port?") from None


class RayBackend:
    """Runs trials as Ray tasks.

    Args:
        address: ``HOST:PORT`` of a running cluster's head, ``"auto"`` for the cluster this machine belongs to, or
            None to start a private single-machine Ray for the sweep.
        trial_timeout: Wall seconds a trial may take from submission; then it is cancelled and recorded as an error.
        runtime_env: Ray's runtime environment for this run's job (e.g. ``{"working_dir": folder}``: the folder
            is uploaded to the cluster and is each worker's working directory and first ``sys.path`` entry, so
            extra plugin modules in it import there). Ray accepts local folders only for a whole job, so the run
            must be the one that connects (Ray not already initialised in this process).
    """

    def __init__(self, address: str | None = None, *, trial_timeout: float | None = None,
                 runtime_env: dict[str, Any] | None = None) -> None:
        self.address = address
        self.timeout = trial_timeout
        self.runtime_env = runtime_env
        self.ray: Any = None

    def _connect(self) -> bool:
        try:
            import ray
        except ImportError:
            raise UserError("--backend ray needs Ray: pip install 'robokit[ray]'") from None
        self.ray = ray
        if ray.is_initialized():
            if self.runtime_env:
                raise RuntimeError("Ray is already initialised in this process: a runtime_env with local files "
                                   "can only be given to the run that connects")
            return False
        _probe(self.address)
        try:
            ray.init(address=self.address, log_to_driver=False, logging_level=logging.ERROR, include_dashboard=False,
                     runtime_env=self.runtime_env)
        except (ConnectionError, getattr(ray.exceptions, "AuthenticationError", ConnectionError)):  # older Rays: none
            raise UserError(connect_error(self.address)) from None
        return True

    def run(self, tasks: Sequence[TrialTask]) -> Iterator[dict[str, Any]]:
        """Yield one row per task as trials finish. Closing the iterator cancels what is still running."""
        if not tasks:
            return
        started_here = self._connect()
        ray = self.ray
        remote = ray.remote(num_cpus=1, max_retries=1, max_calls=MAX_CALLS)(run_trial_safely)
        capacity = max(1, int(ray.cluster_resources().get("CPU", 1)))
        queue: deque[TrialTask] = deque(tasks)
        pending: dict[Any, tuple[TrialTask, float]] = {}
        try:
            while queue or pending:
                while queue and len(pending) < capacity:
                    task = queue.popleft()
                    pending[remote.remote(task)] = (task, time.monotonic())
                yield from self._collect(pending)
        finally:
            for ref in pending:
                ray.cancel(ref, force=True)
            if started_here:
                ray.shutdown()

    def _collect(self, pending: dict[Any, tuple[TrialTask, float]]) -> Iterator[dict[str, Any]]:
        ray = self.ray
        wait_for = None
        if self.timeout is not None:
            wait_for = max(0.0, min(t0 for _, t0 in pending.values()) + self.timeout - time.monotonic())
        ready, _ = ray.wait(list(pending), num_returns=1, timeout=wait_for)
        for ref in ready:
            task, t0 = pending.pop(ref)
            try:
                yield ray.get(ref)
            except ray.exceptions.WorkerCrashedError as exc:
                yield error_row(task, f"worker died twice running this trial (Ray retried it once): {exc}",
                                worker="ray", wall_time=time.monotonic() - t0)
            except ray.exceptions.RayError as exc:
                yield error_row(task, f"Ray: {type(exc).__name__}: {str(exc).splitlines()[0]}", worker="ray",
                                wall_time=time.monotonic() - t0)
        if self.timeout is None:
            return
        now = time.monotonic()
        for ref, (task, t0) in list(pending.items()):
            if now - t0 >= self.timeout:
                ray.cancel(ref, force=True)
                del pending[ref]
                yield error_row(task, f"timed out: no result after {self.timeout:g} s (--trial-timeout); Ray task "
                                      f"cancelled and its worker killed", worker="ray", wall_time=now - t0)
