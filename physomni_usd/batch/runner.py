"""Running a shot list on Ray: one Ray task per shot, each running :func:`physomni_usd.run` in its own process.

The driver skips finished shots, submits the rest (at most ``workers`` at a
time), and resubmits a shot whose attempt failed in a way a retry can help: a
crash, a killed process or worker, a lost node, a stage that failed (a diverged
simulation). Bad input (exit code 2) is not retried. Nothing a shot does
reaches another: each runs in its own process (:mod:`.child`) with its log in
its own folder, and tells its failure as a structured
:class:`physomni_usd.failure.Failure` (stage, exception type, message, exit
code), which the summary keeps.

Paths are read where the task runs, so a cluster must see the shot list's
folder and the output folders at the same paths as the driver (shared storage).
"""

from __future__ import annotations

import errno
import json
import logging
import os
import pathlib
import pickle
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass, field

from .._files import write_bytes
from ..errors import InputError, PhysOmniError
from ..failure import Failure
from ..limits import Limit, Limits
from .shots import LOG, OUTPUTS, Shot, inputs_hash, is_finished, mark_finished, mark_started, missing_input

#: The object store holds only each shot's small result; Ray's default (30 % of memory) is wasted here.
LOCAL_OBJECT_STORE_BYTES = 256 * 1024 * 1024
_POLL_S = 0.5

def run_shot(call, args: list[str], cwd: str, output: str, digest: str, attempt: int,
             files: dict | None = None) -> dict:
    """One attempt of one shot, in the Ray worker: :func:`physomni_usd.run` with the keyword arguments
    ``call(args)`` gives, in a child process (:mod:`.child`) working in ``cwd``.

    Returns ``{'ok', 'retry', 'reason', 'failure', 'seconds', 'node', 'node_ip', 'node_id'}``; ``failure``
    is the child's structured failure (None when it ended without telling one: killed). With ``files``
    (``--upload``) the shot runs in a temporary folder holding them, and the result carries its
    output folder as ``'archive'`` (tar bytes) for the driver to unpack.
    """
    import ray

    where = {"node": socket.gethostname(), "node_ip": ray.util.get_node_ip_address(),
             "node_id": ray.get_runtime_context().get_node_id()}
    if files is not None:
        from .upload import pack, write_staged

        root = pathlib.Path(tempfile.mkdtemp(prefix="physomni-shot-"))
        try:
            write_staged(root, files)
            result = run_shot(call, args, str(root), str(root / "out"), digest, attempt, files=None)
            result["archive"] = pack(root / "out")
            return result
        finally:
            shutil.rmtree(root, ignore_errors=True)
    folder = pathlib.Path(output)
    t0 = time.perf_counter()
    try:
        folder.mkdir(parents=True, exist_ok=True)
        mark_started(folder)
        # O_NOFOLLOW: a log planted as a link in a shot folder must not carry our appends to a file elsewhere
        log = os.fdopen(os.open(folder / LOG, os.O_WRONLY | os.O_APPEND | os.O_CREAT | os.O_NOFOLLOW, 0o666), "ab")
    except PhysOmniError as exc:  # a report.json that is a link (refused, never written through)
        return {"ok": False, "retry": False, "reason": str(exc), "seconds": 0.0, **where}
    except OSError as exc:
        why = "it is a symbolic link" if exc.errno == errno.ELOOP else (exc.strerror or exc)
        return {"ok": False, "retry": False, "reason": f"cannot write output {folder / LOG}: {why}",
                "seconds": 0.0, **where}
    with log:
        log.write(f"== attempt {attempt} on {where['node']} ({where['node_ip']}), "
                  f"{time.strftime('%Y-%m-%d %H:%M:%S')}: physomni-usd run {' '.join(args)}\n".encode())
        log.flush()
        env = dict(os.environ, PYTHONUNBUFFERED="1")
        told, tell = os.pipe()
        try:
            proc = subprocess.Popen([sys.executable, "-m", "physomni_usd.batch.child", str(os.getpid()), str(tell),
                                     "run", *args], cwd=cwd, stdin=subprocess.PIPE, stdout=log,
                                    stderr=subprocess.STDOUT, env=env, pass_fds=(tell,))
        finally:
            os.close(tell)
        with os.fdopen(told, "rb") as answer:
            try:
                proc.stdin.write(pickle.dumps(call))
                proc.stdin.close()
            except BrokenPipeError:  # the child is already gone; its exit code says how
                pass
            failure = _failure(answer.read())
        code = proc.wait()
        seconds = round(time.perf_counter() - t0, 3)
        log.write(f"== exit code {code} after {seconds:.1f} s\n".encode())
    if code == 0:
        missing = [name for name in OUTPUTS if not (folder / name).is_file()]
        if missing:
            return {"ok": False, "retry": True, "seconds": seconds, **where,
                    "reason": f"run ended without {', '.join(missing)}"}
        mark_finished(folder, digest, attempts=attempt, seconds=seconds, **where)
        return {"ok": True, "retry": False, "reason": None, "failure": None, "seconds": seconds, **where}
    return {"ok": False, "retry": code != 2, "reason": failure["message"] if failure else _ended(code),
            "failure": failure, "seconds": seconds, **where}


def _failure(told: bytes) -> dict | None:
    """The child's structured failure, from the line it wrote (None if it wrote none)."""
    try:
        return json.loads(told.decode()) if told.strip() else None
    except (UnicodeDecodeError, json.JSONDecodeError):
        return None


def _ended(code: int) -> str:
    """How a child that told no failure ended."""
    if code < 0:
        try:
            return f"killed by {signal.Signals(-code).name}"
        except ValueError:
            return f"killed by signal {-code}"
    return f"run exited with code {code}"


@dataclass
class Entry:
    """One shot's line of the summary."""

    shot: Shot
    status: str = "pending"  # pending, running, ok, skipped, failed
    attempts: int = 0
    seconds: float = 0.0
    node: str | None = None
    node_ip: str | None = None
    node_id: str | None = None
    reason: str | None = None
    failure: dict | None = None  # the last attempt's structured failure: stage, type, message, exit_code
    digest: str = field(default="", repr=False)

    def as_json(self) -> dict:
        out = {"shot": self.shot.where, "output": str(self.shot.output), "status": self.status,
               "seconds": round(self.seconds, 3), "attempts": self.attempts, "node": self.node,
               "node_ip": self.node_ip, "node_id": self.node_id,
               "log": str(self.shot.output / LOG) if self.attempts else None}
        if self.status == "failed":
            out["reason"] = self.reason
            out["failure"] = self.failure
        return out


class Quiet:
    """A progress display that shows nothing (the interface ``run_batch`` reports to)."""

    def start(self, entries: list[Entry]): ...

    def update(self, entries: list[Entry]): ...

    def event(self, kind: str, entry: Entry): ...

    def close(self): ...


def start_ray(address: str | None, include_gpus: bool = True) -> str:
    """Connect to the cluster at ``address``, or start Ray on this machine with its CPUs; returns where."""
    import ray

    quiet = {"logging_level": logging.ERROR, "log_to_driver": False}
    if address:
        try:
            ray.init(address=address, **quiet)
        except Exception as exc:  # ray raises ConnectionError, RuntimeError, ValueError… by version
            raise InputError(f"--address {address}: cannot connect to a Ray cluster "
                             f"({' '.join(str(exc).split())[:200]})") from None
        return address
    ray.init(address="local", num_cpus=os.cpu_count() or 1, include_dashboard=False,
             object_store_memory=LOCAL_OBJECT_STORE_BYTES, **quiet)
    return "local"


#: The batch's own numbers (``run_batch``'s arguments), with their options, defaults and ranges.
LIMITS = Limits(
    workers=Limit("--workers", "At most this many shots at once", 1, None, None, whole=True,
                  default_text="as many as the CPUs (GPUs) allow"),
    retries=Limit("--retries", "Attempts after the first for a shot that crashed, was killed or whose stage "
                               "failed (never for bad input).", 0, 20, 2, whole=True),
    cpus_per_shot=Limit("--cpus-per-shot", "CPUs Ray reserves for each shot.", 0, None, 1.0, lo_open=True),
    gpus_per_shot=Limit("--gpus-per-shot", "GPUs Ray reserves for each shot (0.25: four shots share one); Ray "
                                           "sets CUDA_VISIBLE_DEVICES to the reserved ones. Give at least a "
                                           "fraction to run shots on GPUs.", 0, None, 0.0),
)


def check_batch(summary_path: pathlib.Path | None = None, **numbers) -> None:
    """Refuse (InputError, before the shot list is read) ``numbers`` (``run_batch``'s: :data:`LIMITS`) out of
    range, a machine without Ray and a summary whose folder does not exist."""
    LIMITS.check(**numbers)
    try:
        import ray  # noqa: F401
    except ImportError:
        raise InputError("batch needs Ray: pip install 'physomni-usd[batch]'") from None
    if summary_path is not None and not pathlib.Path(summary_path).parent.resolve().is_dir():
        raise InputError(f"--summary {summary_path}: folder {pathlib.Path(summary_path).parent} does not exist")


def run_batch(shots: list[Shot], *, address: str | None = None, workers: int | None = None, retries: int = 2,
              force: bool = False, cpus_per_shot: float = 1.0, gpus_per_shot: float = 0.0, progress=None,
              summary_path: pathlib.Path | None = None, upload=None, call) -> dict:
    """Run every unfinished shot; returns the summary (also written to ``summary_path`` after each shot).

    ``call``: a shot's arguments → the keyword arguments of :func:`physomni_usd.run` (``run``'s own parser;
    a module-level function, pickled by reference into each shot's process). ``upload``: ``run``'s click
    command, to ship inputs and outputs through Ray (see :mod:`.upload`) instead of reading and writing them
    at their paths on every node.
    """
    LIMITS.check(workers=workers, retries=retries, cpus_per_shot=cpus_per_shot, gpus_per_shot=gpus_per_shot)
    progress = progress or Quiet()
    t0 = time.perf_counter()
    entries = [Entry(shot) for shot in shots]
    for e in entries:
        e.digest = inputs_hash(e.shot)
        if not force and is_finished(e.shot.output, e.digest):
            e.status = "skipped"
        elif (reason := missing_input(e.shot)) is not None:
            e.status, e.reason = "failed", reason
            e.failure = Failure(reason, 2, "InputError", "check").as_json()
    todo = [e for e in entries if e.status == "pending"]
    state = {"where": None}

    def summary() -> dict:
        counts = {s: sum(e.status == s for e in entries) for s in ("ok", "skipped", "failed")}
        return {"shots": [e.as_json() for e in entries], **counts, "seconds": round(time.perf_counter() - t0, 3),
                "ray": state["where"], "retries": retries}

    def save():
        if summary_path:
            write_bytes(summary_path, (json.dumps(summary(), indent=2) + "\n").encode())

    progress.start(entries)
    for e in entries:
        if e.status != "pending":
            progress.event(e.status, e)
    save()
    if todo:
        import ray

        state["where"] = start_ray(address)
        try:
            _drive(ray, todo, entries, workers, retries, cpus_per_shot, gpus_per_shot, progress, save, upload, call)
        except KeyboardInterrupt:
            for e in todo:
                if e.status in ("pending", "running"):
                    e.status, e.reason = "failed", "the batch was interrupted; run it again to resume"
            save()
            raise
        finally:
            progress.close()
            ray.shutdown()
    else:
        progress.close()
    save()
    return summary()


def _drive(ray, todo, entries, workers, retries, cpus_per_shot, gpus_per_shot, progress, save, upload, call):
    task = ray.remote(run_shot).options(num_cpus=cpus_per_shot, num_gpus=gpus_per_shot, max_retries=0,
                                        name="physomni-usd run")
    queue = list(todo)
    running: dict = {}
    staged: dict = {}  # shot → (args, files in the object store), for --upload
    limit = workers or len(todo)
    try:
        while queue or running:
            while queue and len(running) < limit:
                e = queue.pop(0)
                e.status, e.attempts = "running", e.attempts + 1
                s = e.shot
                if upload is None:
                    ref = task.remote(call, list(s.args), str(s.cwd), str(s.output), e.digest, e.attempts)
                else:
                    if id(e) not in staged:
                        from .upload import stage

                        args, files = stage(s, upload)
                        staged[id(e)] = (args, ray.put(files))
                        mark_started(s.output)
                    args, files = staged[id(e)]
                    ref = task.remote(call, args, str(s.cwd), str(s.output), e.digest, e.attempts, files)
                running[ref] = e
            progress.update(entries)
            done, _ = ray.wait(list(running), num_returns=1, timeout=_POLL_S)
            for ref in done:
                e = running.pop(ref)
                try:
                    result = ray.get(ref)
                except ray.exceptions.RayError as exc:
                    # the worker or its node died under the shot: the process is gone, a retry can help
                    result = {"ok": False, "retry": True, "seconds": 0.0, "failure": None,
                              "reason": f"the Ray worker was lost ({type(exc).__name__})"}
                if result.get("archive") is not None:
                    from .upload import unpack

                    unpack(result.pop("archive"), e.shot.output)
                e.seconds += result.get("seconds") or 0.0
                for key in ("node", "node_ip", "node_id"):
                    setattr(e, key, result.get(key, getattr(e, key)))
                e.failure = result.get("failure")
                if result["ok"]:
                    e.status, e.reason = "ok", None
                    progress.event("ok", e)
                elif result["retry"] and e.attempts <= retries:
                    e.status, e.reason = "pending", result["reason"]
                    progress.event("retry", e)
                    queue.append(e)
                else:
                    e.status, e.reason = "failed", result["reason"]
                    progress.event("failed", e)
                save()
    finally:
        for ref in running:
            ray.cancel(ref, force=True)
