"""Synthetic walker depth-camera sessions with exact ground truth (issue 3).

Main API: :class:`SessionSpec` (+ :meth:`SessionSpec.preset`), :func:`generate_session`,
:func:`write_session`; CLI ``python -m walker_gait.synth`` (:func:`walker_gait.synth.cli.main`).
"""

from walker_gait.synth.export import write_session
from walker_gait.synth.session import SCENARIOS, Session, SessionSpec, generate_session

__all__ = ["SCENARIOS", "Session", "SessionSpec", "generate_session", "write_session"]
