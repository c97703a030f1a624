"""Benchmarks, the synthetic sweep and the probe battery (``python -m walker_gait.bench``, ``.sweep``, ``.probes``).

They measure with numpy's BLAS on one thread, as ``walker-gait`` runs (:func:`walker_gait.limit_blas_threads`, here
before any of them imports numpy): run directly with OpenBLAS's default threads, a two-job sweep's threads spun
against each other and the tracker took 28.8 ms a frame instead of 17.7 (set C, 328 s against 221 s a sweep, the
same figures; eighty-third session)."""

from walker_gait import limit_blas_threads

limit_blas_threads()
