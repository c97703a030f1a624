"""Compiled inner loops of the tracker (numba), with the numpy code of :mod:`likelihood`, :mod:`leg_model` and
:mod:`tracker` as the fallback.

The tracker spends most of its time in three loops over particles: the pairwise distances of the 3D cue
(skeleton points x foreground points), the capsule renderer of the 2D cue and its per-pixel costs.  In numpy
each is a sequence of whole-array passes over ``(P, M, N)`` / ``(P, h, w)`` temporaries; compiled, each is one
pass whose inner loop the compiler vectorises (about 4x faster for each on this project's 2-core machine; the
tracker's frame 2x, see DEVELOPERS.md).

* :func:`render_boxes` computes exactly the float32 operations of the numpy renderer, in the same order, so
  its image is bit-identical (tested).
* :func:`surface_costs` computes each distance directly as ``sqrt(dx² + dy² + dz²)`` instead of numpy's
  ``|a|² - 2 a·b + |b|²`` (one matrix product); the two agree to float32 rounding (tested), the direct form
  being the more accurate one.
* :func:`depth_cost_sums` sums :func:`likelihood.depth_costs`'s float32 pixel costs per particle in float64
  (in another order than numpy: the same log likelihoods to ~1e-12, tested).

Around those loops the tracker spent as much time again in numpy calls on small arrays (a few hundred elements each,
call overhead rather than arithmetic).  Four more kernels take the largest groups of them, each computing numpy's
float64 arithmetic term by term (the same products and sums in the same order; the trigonometric functions still
numpy's):

* :func:`leg_chain`: the leg model's forward kinematics, and for :func:`walker_gait.core.leg_model.enforce_constraints`
  its floor contact and collision test: the same kinematics and decisions bit for bit (tested).
* :func:`camera_segments`: the segments moved to the camera frame and the feet's elliptic radii
  (:func:`walker_gait.core.tracker.camera_segments`; numpy's matrix product may fuse a multiply-add: they agree to
  rounding, tested).
* :func:`cue3d_terms`: the 3D cue's skeleton points, its floor cut, occlusion test and truncation around
  :func:`surface_costs` (:func:`likelihood.log_likelihood_3d`; the sums stay numpy's).
* :func:`prior_angle_args` / :func:`prior_terms`: the pose priors of the tracker's ``_evaluate``, in two passes
  around numpy's ``arctan2`` and ``arcsin`` (on AVX-512 numpy's are SVML's, not the C library's that numba calls):
  bit for bit (tested).

Together the tracker's frame went from 25 to 14 ms on the default preset with the same tracks, steps and events,
bit for bit, on the 96 sessions of three sweep sets (sixty-seventh session, DEVELOPERS.md).

The feet's measures (:mod:`walker_gait.core.feet`) pick the points they take from the whole foreground with three
more (:func:`toe_sides`, :func:`shoe_near`, :func:`shoe_strip`): one pass each instead of a dozen numpy masks, the
same points in the same order (the distances agree to rounding, tested); the measures themselves stay numpy's.

The segmentation (:mod:`walker_gait.core.segmentation`) runs four of its full-image passes compiled, each
computing numpy's float32 (or float64) arithmetic pixel by pixel, so its masks, points and counters are numpy's bit
for bit (tested): :func:`walker_box` (the walker coordinates, the floor's threshold, the box and its reach band),
:func:`static_pixels` (the learned structure's pixels), :func:`thin_parts` (the runs, metric widths and verdicts)
and :func:`transient_no_depth` (the running share of frames without depth).  Together the segmentation's frame went
from ~7.5 to ~5.3 ms on the 2-core Intel VM (sixty-eighth session, DEVELOPERS.md).  :func:`back_project` is
:meth:`walker_gait.core.depth.DepthProjector.points` in one pass (0.7 -> 0.3 ms for 640x480).  These take their
input arrays read-only (a depth image may be a message's buffer), which writable arrays match too.

``compiled()`` returns this module's kernels, or None when numba is not installed or the environment
variable ``WALKER_GAIT_JIT=0`` turns them off; the tracker then runs its numpy code.  numba is
imported on first use (not when the package is imported), and the kernels are cached on disk
(``__pycache__``, or numba's user-wide cache directory where that is not writable), so only the first
process after an install pays the compilation (several seconds, README).
"""

from __future__ import annotations

import functools
import os
import warnings
from types import ModuleType

ENV = "WALKER_GAIT_JIT"
"""Environment variable: ``0`` runs the likelihood in numpy even when numba is installed."""


@functools.cache
def compiled() -> ModuleType | None:
    """The compiled kernels (:mod:`walker_gait.core._jit`), or None (numba missing or turned off)."""
    if os.environ.get(ENV, "1").strip().lower() in ("0", "false", "no", "off"):
        return None
    try:
        from walker_gait.core import _jit
    except ImportError:  # numba not installed: the numpy code, as documented
        return None
    except Exception as exc:  # noqa: BLE001 - a broken numba/llvmlite install must not stop the tracker
        warnings.warn(f"walker_gait: the likelihood's compiled kernels failed to load ({type(exc).__name__}: {exc}); "
                      f"running its numpy code (about twice as slow; {ENV}=0 silences this)", RuntimeWarning,
                      stacklevel=2)
        return None
    return _jit


__all__ = ["ENV", "compiled"]
