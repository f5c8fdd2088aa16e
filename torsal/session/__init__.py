"""Live design: :class:`Session` keeps one design warm in a long-running process and answers
edits with a preview first (the congruence, the fins as surfaces, the light, in about a
second at paper size), then the built design from a background thread.

Between the pipeline and the study: it may import the pipeline and below; the hosts (the
FreeCAD object, notebooks) import it.
"""
from .answer import BUILT_STAGES, PREVIEW_STAGES, AnswerKind, SessionAnswer
from .build import BuildCancelled
from .edits import RegionGoal, SessionEditError, apply_edit, edit_keys
from .session import Session

__all__ = ["Session", "SessionAnswer", "AnswerKind", "RegionGoal", "SessionEditError",
           "BuildCancelled", "apply_edit", "edit_keys", "PREVIEW_STAGES", "BUILT_STAGES"]
