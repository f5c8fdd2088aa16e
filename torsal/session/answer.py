"""What a live session answers: :class:`SessionAnswer`, of a kind (:class:`AnswerKind`)."""
from __future__ import annotations

from dataclasses import dataclass, field
from enum import Enum
from pathlib import Path

from ..pipeline.design_file import DesignSpec

__all__ = ["AnswerKind", "SessionAnswer", "PREVIEW_STAGES", "BUILT_STAGES"]

#: the stages a preview runs (when their inputs changed): what a designer looks at
PREVIEW_STAGES = ("surface", "estimate", "sun", "orient", "congruence", "remesh", "support",
                  "substructure", "devices", "light")
#: the stages only a built answer runs: solids, sheets, the assembly check, the files
BUILT_STAGES = ("fabrication", "annual", "assembly", "report")


class AnswerKind(str, Enum):
    """What an answer of a :class:`~torsal.session.Session` is.

    ``preview``: the congruence, the support structure's fins as surfaces and the light
    figures of every fin, right after an edit. ``built``: the whole design run (solids,
    sheets, assembly check, every file in the session's folder). ``infeasible``: the edit
    cannot be made (bad geometry, an optimization that does not converge, a stage that
    rejects it); the session keeps the last good design. ``error``: a bug in torsal (the
    answer's ``error`` holds the exception); the session keeps the last good design too.
    """

    PREVIEW = "preview"
    BUILT = "built"
    INFEASIBLE = "infeasible"
    ERROR = "error"


@dataclass(frozen=True)
class SessionAnswer:
    """One answer of a live session.

    Attributes
    ----------
    kind : AnswerKind
    revision : int
        The edit this answers (0: the design the session started with; each edit adds 1,
        an infeasible one too).
    spec : DesignSpec
        The design answered: the edited one, or for ``infeasible`` / ``error`` the last good
        design the session keeps.
    stages_run : tuple of str
        The stages computed for this answer, in order.
    stages_kept : tuple of str
        The stages taken from the session's warm results (or the stage cache) unchanged.
    seconds : float
        Wall time from the edit to this answer, seconds (a built answer counts from the edit,
        so it includes the preview).
    stage_seconds : dict
        Seconds of each stage run for this answer.
    values : dict
        Stage name -> the stage's result (``values["congruence"]["directions"]`` (n, 3),
        ``values["support"]["structure"]``, ...), of ``spec``.
    report : dict
        The report sections so far (as ``report.json`` has them): a preview's has
        ``congruence``, ``support``, ``light``; a built answer's every section.
    devices_current : bool
        False when the light's comparison with the standard devices (``light.devices``,
        ``light.baseline_louvers``) waits for the built answer (a change of spacing or
        depth); those keys are then left out of a preview's ``light``.
    support_final : bool
        False when the preview's fins were made planar by a projection because eq. (8)'s soft
        planarity did not make them planar in a few iterations (a let-through region: the
        design run then solves it with planarity as a hard constraint, seconds): the built
        answer's fins are the design run's (``report["support"]["status"]`` says which).
        True: the preview's support structure is the design run's.
    folder : Path or None
        A built answer's output folder (its files are ``files``).
    files : dict
        A built answer's files, relative to ``folder``.
    message : str
        Why an edit is infeasible (naming the stage and key), or the error's message.
    error : BaseException or None
        The exception of an ``infeasible`` or ``error`` answer.
    """

    kind: AnswerKind
    revision: int
    spec: DesignSpec
    stages_run: tuple[str, ...] = ()
    stages_kept: tuple[str, ...] = ()
    seconds: float = 0.0
    stage_seconds: dict = field(default_factory=dict)
    values: dict = field(default_factory=dict, repr=False)
    report: dict = field(default_factory=dict, repr=False)
    devices_current: bool = True
    support_final: bool = True
    folder: Path | None = None
    files: dict = field(default_factory=dict, repr=False)
    message: str = ""
    error: BaseException | None = field(default=None, repr=False)

    @property
    def ok(self) -> bool:
        """True for a preview or a built answer (the edit was made)."""
        return self.kind in (AnswerKind.PREVIEW, AnswerKind.BUILT)

    @property
    def congruence(self):
        """The optimized :class:`~torsal.geometry.congruence.Congruence` over the oriented
        mesh A (model units), None before any good design."""
        from ..geometry.congruence import Congruence

        if "congruence" not in self.values:
            return None
        o = self.values["orient"]
        return Congruence(o["vertices"], o["faces"], self.values["congruence"]["directions"])

    @property
    def structure(self):
        """The support structure (:class:`~torsal.geometry.structure.SupportStructure`) whose
        edges are the fins, model units; None before any good design."""
        return self.values.get("support", {}).get("structure")

    @property
    def light(self) -> dict:
        """The light figures (``report["light"]``): ``blocked_share``, ``view_clear``, ..."""
        return self.report.get("light", {})

    def fins(self):
        """The fins as surfaces: a ``trimesh.Trimesh`` of the fin quads (model units), None
        before any good design.

        >>> answer.fins().area  # doctest: +SKIP
        187.3
        """
        s = self.structure
        return None if s is None else s.fin_mesh()
