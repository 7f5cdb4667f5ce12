"""Training environments in worker processes that fail loudly instead of hanging the trainer.

SB3's ``SubprocVecEnv`` worker simply dies when its environment raises, and the trainer then
sees a bare ``EOFError`` / ``BrokenPipeError``; a worker that is alive but stuck (a planner that
never returns) blocks ``remote.recv()`` forever. Here:

- ``WorkerErrorLog`` wraps each worker's environment: an exception in ``step`` or ``reset`` is
  appended, with its traceback and the worker's pid, to ``RUN_DIR/worker_errors.log`` before it
  is re-raised (and kills the worker, as before);
- ``GuardedSubprocVecEnv`` is SB3's ``SubprocVecEnv`` whose pipe ends wait at most
  ``timeout_s`` for a reply (``run.worker_timeout_s``) and turn a dead or stuck worker into
  ``EnvWorkerError``: the worker's index and the reason, i.e. the last line of its logged
  traceback, the signal that killed it or its exit code, or ``no reply in N s``. ``close`` after
  a failure terminates (then kills) the remaining workers instead of waiting on them.

``relmogen.experiments.session.learn`` catches ``EnvWorkerError``, writes a checkpoint (model and
replay) and re-raises it with the run directory and the checkpoint's episode filled in; the CLI
prints it as one line and exits with status 1.
"""

from __future__ import annotations

import os
import signal
import time
import traceback
from pathlib import Path

import gymnasium as gym
from stable_baselines3.common.vec_env import SubprocVecEnv

WORKER_ERRORS = "worker_errors.log"
ENTRY_MARK = "=== worker pid "  # each logged error starts with this line: "=== worker pid P: step"
PIPE_ERRORS = (EOFError, BrokenPipeError, ConnectionResetError)
POLL_SLICE_S = 1.0  # how often a waiting recv checks that its worker is still alive


class EnvWorkerError(RuntimeError):
    """An environment worker died or stopped answering. ``run_dir`` and ``episodes`` are set by
    the trainer once it has written its checkpoint."""

    def __init__(self, index: int, reason: str):
        super().__init__(index, reason)
        self.index, self.reason = index, reason
        self.run_dir: Path | None = None
        self.episodes: int | None = None

    def __reduce__(self):  # Ray and multiprocessing pickle it: keep run_dir and episodes
        return (type(self), (self.index, self.reason), {"run_dir": self.run_dir, "episodes": self.episodes})

    def __str__(self) -> str:
        text = f"environment worker {self.index} died: {self.reason}"
        if self.run_dir is not None:
            text += (f"; checkpoint at episode {self.episodes} written; "
                     f"continue with: relmogen train --resume {self.run_dir}")
        return text


class WorkerErrorLog(gym.Wrapper):
    """Appends the traceback of an exception in ``step`` / ``reset`` to ``log_path``, then re-raises."""

    def __init__(self, env: gym.Env, log_path: str | os.PathLike | None = None):
        super().__init__(env)
        self.log_path = None if log_path is None else Path(log_path)

    def step(self, action):
        try:
            return self.env.step(action)
        except Exception:
            self._log("step")
            raise

    def reset(self, **kwargs):
        try:
            return self.env.reset(**kwargs)
        except Exception:
            self._log("reset")
            raise

    def _log(self, where: str) -> None:
        if self.log_path is None:
            return
        entry = f"{ENTRY_MARK}{os.getpid()}: {where} at {time.strftime('%Y-%m-%dT%H:%M:%S')}\n{traceback.format_exc()}"
        with open(self.log_path, "a") as handle:  # one write per entry: workers may log at once
            handle.write(entry if entry.endswith("\n") else entry + "\n")


def last_logged_error(log_path: Path | None, pid: int) -> str | None:
    """The final line (``Type: message``) of the newest traceback logged by worker ``pid``."""
    if log_path is None or not Path(log_path).is_file():
        return None
    last = None
    for entry in Path(log_path).read_text().split(ENTRY_MARK)[1:]:
        head, _, body = entry.partition("\n")
        lines = [line for line in body.splitlines() if line.strip()]
        if head.split(":", 1)[0].strip() == str(pid) and lines:
            last = lines[-1].strip()
    return last


def exit_reason(exitcode: int | None) -> str:
    if exitcode is None:
        return "its pipe closed"
    if exitcode < 0:
        try:
            return f"killed by signal {signal.Signals(-exitcode).name}"
        except ValueError:
            return f"killed by signal {-exitcode}"
    return f"exited with code {exitcode}"


class _TimedPipe:
    """The trainer's end of one worker's pipe: ``recv`` waits at most ``timeout_s``; a closed pipe
    or a dead worker becomes ``EnvWorkerError``. Everything else goes to the connection."""

    def __init__(self, conn, index: int, venv: GuardedSubprocVecEnv):
        self._conn, self._index, self._venv = conn, index, venv

    def send(self, message) -> None:
        try:
            self._conn.send(message)
        except PIPE_ERRORS + (OSError,):
            raise self._venv._failure(self._index) from None

    def recv(self):
        deadline = time.monotonic() + self._venv.timeout_s
        process = self._venv.processes[self._index]
        while not self._conn.poll(max(0.0, min(POLL_SLICE_S, deadline - time.monotonic()))):
            if not process.is_alive():
                raise self._venv._failure(self._index)
            if time.monotonic() >= deadline:
                raise self._venv._failure(self._index, f"no reply in {self._venv.timeout_s:g} s (stuck; killed)")
        try:
            return self._conn.recv()
        except PIPE_ERRORS + (OSError,):
            raise self._venv._failure(self._index) from None

    def __getattr__(self, name):
        return getattr(self._conn, name)


class GuardedSubprocVecEnv(SubprocVecEnv):
    """``SubprocVecEnv`` with a per-reply timeout and ``EnvWorkerError`` for dead or stuck workers."""

    def __init__(self, env_fns, start_method: str | None = None, timeout_s: float = 600.0,
                 error_log: str | os.PathLike | None = None):
        self.timeout_s, self.error_log = float(timeout_s), None if error_log is None else Path(error_log)
        self.failure: EnvWorkerError | None = None
        try:
            super().__init__(env_fns, start_method)  # its first reply (the spaces) comes from worker 0
        except PIPE_ERRORS:
            self.processes = getattr(self, "processes", [])
            error = self._failure(0)
            self._stop_workers()
            raise error from None
        self.remotes = tuple(_TimedPipe(remote, index, self) for index, remote in enumerate(self.remotes))

    def step_wait(self):
        self._raise_if_failed()
        return super().step_wait()

    def reset(self):
        self._raise_if_failed()
        return super().reset()

    def close(self) -> None:
        if self.closed:
            return
        if self.failure is None:
            try:
                return super().close()
            except EnvWorkerError:
                pass
        self._stop_workers()

    def _raise_if_failed(self) -> None:
        if self.failure is not None:
            raise self.failure

    def _failure(self, index: int, reason: str | None = None) -> EnvWorkerError:
        """The error for worker ``index`` (the first one found is kept: later calls repeat it)."""
        if self.failure is not None:
            return self.failure
        process = self.processes[index] if index < len(self.processes) else None
        if reason is None and process is not None:
            process.join(timeout=5)  # the pipe closes a moment before the exit code is known
            reason = last_logged_error(self.error_log, process.pid) or exit_reason(process.exitcode)
        self.failure = EnvWorkerError(index, reason or "its pipe closed")
        return self.failure

    def _stop_workers(self) -> None:
        """Ends every worker without waiting on its pipe: terminate, then kill."""
        for process in self.processes:
            if process.is_alive():
                process.terminate()
        for process in self.processes:
            process.join(timeout=5)
            if process.is_alive():
                process.kill()
                process.join(timeout=5)
        for remote in getattr(self, "remotes", ()):
            try:
                remote.close()
            except OSError:
                pass
        self.closed = True
