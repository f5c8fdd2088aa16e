"""The FreeCAD object on a live session: one torsal process per fins object keeps its design
warm (:class:`torsal.session.Session`); a property change is answered with the preview (the
fins as surfaces) at once, the solids when they are built.

Two sides of one line protocol (JSON, one message a line):

- :func:`serve` runs in torsal's Python (``python -m torsal.hosts.freecad --live``): it
  reads ``{"op": "edit", "id": n, "job": FinsJob}`` and ``{"op": "close"}`` on stdin and
  writes ``{"kind": "preview" | "infeasible" | "error", "id": n, ...}`` for each edit, then
  ``{"kind": "built" | "built-failed", "id": n, ...}`` when the edit's build ends (an edit
  that comes first cancels it: no message). Lengths in messages are FreeCAD's millimetres.
- :class:`LiveClient` runs in FreeCAD's Python: it starts that process, sends the object's
  job and reads the answers (a thread collects them, so FreeCAD never blocks on the pipe).

Why a process of its own: see :mod:`torsal.hosts.freecad.job` (FreeCAD and torsal load
different OpenCascades and numpys).
"""
from __future__ import annotations

import json
import os
import queue
import subprocess
import sys
import threading
from dataclasses import asdict
from pathlib import Path

from ...core.errors import TorsalError
from ...core.units import scale
from ...pipeline.design import DesignResult
from ...session import AnswerKind, Session, SessionAnswer
from .job import FinsJob, FinsOutcome, outcome_of, write_design

__all__ = ["serve", "LiveClient", "LiveError", "fins_message", "built_message", "outcome_from"]


class LiveError(TorsalError, RuntimeError):
    """The live session's process ended or did not answer; the message has its last words."""


def fins_message(answer: SessionAnswer) -> dict:
    """A preview's fins for FreeCAD: ``a`` (n, 3) the fin corners on the A side in mm, ``b``
    and ``b1`` (n, 3) those on the B side of family 0's and of family 1's fins (each family
    at its own depth, ``fins.depth = [d0, d1]``), ``edges`` (k, 2) and ``families`` (k,): a
    fin of family f is the quad ``a_i a_j b_j b_i`` with ``b`` of its family.

    >>> fins_message(answer)["edges"][:2]   # doctest: +SKIP
    [[0, 1], [1, 2]]
    """
    s, mm = answer.structure, scale(answer.spec.units, "mm")
    b0, b1 = ((s.family_vertices_b(f) * mm).round(6).tolist() for f in (0, 1))
    return {"a": (s.vertices_a * mm).round(6).tolist(), "b": b0, "b1": b1,
            "edges": s.edges.tolist(), "families": [int(f) for f in s.edge_family]}


def built_message(answer: SessionAnswer, design_path: Path) -> dict:
    """A built answer for FreeCAD: the :class:`~torsal.hosts.freecad.job.FinsOutcome` fields
    (the STEP file, parts, verdicts) and the seconds from the edit.

    >>> built_message(answer, Path("job/design.toml"))["kind"]   # doctest: +SKIP
    'built'
    """
    result = DesignResult(report=answer.report, files=answer.files,
                          stage_seconds=answer.stage_seconds, cached=list(answer.stages_kept),
                          folder=answer.folder)
    return {"kind": "built", "seconds": answer.seconds, **asdict(outcome_of(result, design_path))}


class _Server:
    """One FreeCAD object's session, answering on ``out`` (thread-safe writes)."""

    def __init__(self, out):
        self.out = out
        self.lock = threading.RLock()
        self.session: Session | None = None
        self.folder: Path | None = None
        self.requests: dict[int, tuple[int, Path]] = {}   # revision -> (request id, design)

    def send(self, message: dict) -> None:
        with self.lock:
            self.out.write(json.dumps(message) + "\n")
            self.out.flush()

    def built(self, answer: SessionAnswer) -> None:
        with self.lock:
            rid, design = self.requests.get(answer.revision, (None, None))
            if rid is None:
                return
            if answer.kind is AnswerKind.BUILT:
                self.send({"id": rid, **built_message(answer, design)})
            else:
                self.send({"id": rid, "kind": "built-failed", "message": answer.message})

    def edit(self, rid: int, job: FinsJob) -> None:
        with self.lock:
            try:
                design, spec = write_design(job)
            except (TorsalError, OSError) as exc:
                self.send({"id": rid, "kind": "error", "bad_input": True,
                           "message": "\n".join([str(exc), *getattr(exc, "__notes__", ())])})
                return
            folder = Path(job.folder)
            if self.session is None or folder != self.folder:
                self.close()
                self.session = Session(spec, folder / "out", on_answer=self.built)
                self.folder = folder
            answer = self.session.apply(spec)
            if not answer.ok:
                self.send({"id": rid, "kind": answer.kind.value, "message": answer.message})
                return
            self.requests[answer.revision] = (rid, design)
            self.send({"id": rid, "kind": "preview", "revision": answer.revision,
                       "seconds": answer.seconds, "stages_run": list(answer.stages_run),
                       "stages_kept": list(answer.stages_kept), "design": str(design),
                       "sun_blocked": answer.light.get("blocked_share"),
                       "fins": fins_message(answer)})

    def close(self) -> None:
        if self.session is not None:
            self.session.close()
            self.session = None


def serve(lines, out) -> int:
    """Serve one FreeCAD object's live session: requests from ``lines`` (stdin), answers to
    ``out`` (stdout; anything else the process prints goes to stderr). Returns the exit status
    (0 when ``lines`` ends or says close).

    >>> import io
    >>> serve(io.StringIO('{"op": "close"}\\n'), io.StringIO())
    0
    """
    if lines is sys.stdin:
        # workers forked by the build (the assembly check's) close sys.stdin as they start:
        # it must not be the file this thread waits on, whose lock they would inherit held
        lines = os.fdopen(os.dup(0), "r")
        sys.stdin = open(os.devnull)
    if out is sys.stdout:            # C libraries print to fd 1: only the protocol goes there
        sys.stdout.flush()
        out = os.fdopen(os.dup(1), "w", buffering=1)
        os.dup2(2, 1)
        sys.stdout = sys.stderr
    server = _Server(out)
    try:
        for line in lines:
            if not line.strip():
                continue
            request = json.loads(line)
            if request.get("op") == "close":
                break
            try:
                server.edit(int(request["id"]), FinsJob.from_dict(request["job"]))
            except Exception as exc:         # a bug: said, and the session serves on
                server.send({"id": request.get("id"), "kind": "error", "bad_input": False,
                             "message": f"a bug in torsal: {type(exc).__name__}: {exc}"})
    finally:
        server.close()
    return 0


class LiveClient:
    """FreeCAD's side: a live session process for one fins object.

    Parameters
    ----------
    python : str
        torsal's Python (:func:`~torsal.hosts.freecad.feature.torsal_python`).

    Examples
    --------
    >>> client = LiveClient(torsal_python())            # doctest: +SKIP
    >>> client.ask(job, timeout=600)["kind"]            # doctest: +SKIP
    'preview'
    >>> client.wait_built(timeout=600)["kind"]          # doctest: +SKIP
    'built'
    """

    def __init__(self, python: str):
        env = {k: v for k, v in os.environ.items() if k not in ("PYTHONHOME", "PYTHONPATH")}
        self.proc = subprocess.Popen([python, "-m", "torsal.hosts.freecad", "--live"],
                                     stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                                     stderr=subprocess.PIPE, text=True, env=env, bufsize=1)
        self.messages: queue.Queue = queue.Queue()
        self.stderr: list[str] = []
        self.last_id = 0
        self._built: dict | None = None
        threading.Thread(target=self._read, daemon=True).start()
        threading.Thread(target=self._read_errors, daemon=True).start()

    def _read(self) -> None:
        for line in self.proc.stdout:
            try:
                self.messages.put(json.loads(line))
            except ValueError:
                self.stderr.append(line)
        self.messages.put(None)                       # the process ended

    def _read_errors(self) -> None:
        for line in self.proc.stderr:
            self.stderr = (self.stderr + [line])[-40:]

    @property
    def alive(self) -> bool:
        return self.proc.poll() is None

    def _next(self, timeout: float | None) -> dict:
        try:
            message = self.messages.get(timeout=timeout)
        except queue.Empty:
            raise LiveError(f"torsal's live session did not answer in {timeout} s") from None
        if message is None:
            self.messages.put(None)
            raise LiveError("torsal's live session ended: " + "".join(self.stderr[-12:]).strip())
        if message.get("kind") in ("built", "built-failed"):
            if message.get("id") == self.last_id:
                self._built = message
            return {}
        return message

    def ask(self, job: FinsJob, *, timeout: float | None = 600.0) -> dict:
        """Send ``job`` (the object's properties) and return the session's first answer to it:
        a ``preview`` (``fins``, ``seconds``, ``stages_run``, ...), ``infeasible`` or ``error``."""
        if not self.alive:
            raise LiveError("torsal's live session ended: " + "".join(self.stderr[-12:]).strip())
        self.last_id += 1
        self._built = None
        self.proc.stdin.write(json.dumps({"op": "edit", "id": self.last_id, "job": asdict(job)}) + "\n")
        self.proc.stdin.flush()
        while True:
            message = self._next(timeout)
            if message.get("id") == self.last_id:
                return message

    def take_built(self) -> dict | None:
        """The last edit's built answer if it has come (once), without waiting."""
        keep = []
        while True:
            try:
                message = self.messages.get_nowait()
            except queue.Empty:
                break
            if message is not None and message.get("kind") in ("built", "built-failed"):
                if message.get("id") == self.last_id:
                    self._built = message
                continue
            keep.append(message)             # the end of the process: for the next call
            break
        for message in keep:
            self.messages.put(message)
        built, self._built = self._built, None
        return built

    def wait_built(self, *, timeout: float | None = 600.0) -> dict | None:
        """The last edit's built answer (``built``: a :class:`~torsal.hosts.freecad.job.FinsOutcome`'s
        fields and ``seconds``; ``built-failed``: its ``message``), waiting up to ``timeout``."""
        while self._built is None:
            self._next(timeout)
        built, self._built = self._built, None
        return built

    def close(self, timeout: float = 30.0) -> None:
        """End the session process (its build is cancelled; the output folder stays whole)."""
        if self.alive:
            try:
                self.proc.stdin.write(json.dumps({"op": "close"}) + "\n")
                self.proc.stdin.close()
                self.proc.wait(timeout)
            except (OSError, subprocess.TimeoutExpired):
                self.proc.kill()


def outcome_from(message: dict) -> FinsOutcome:
    """The :class:`~torsal.hosts.freecad.job.FinsOutcome` of a ``built`` message."""
    return FinsOutcome(**{k: v for k, v in message.items() if k not in ("kind", "id", "seconds")})
