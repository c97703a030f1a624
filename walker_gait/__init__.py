"""walker_gait: depth-camera gait analysis for an instrumented wheeled walker."""

__version__ = "0.1.0"


def limit_blas_threads() -> None:
    """Let numpy's BLAS use one thread unless the user chose otherwise (call before numpy is imported).

    The matrices here are small (particles x model points); extra BLAS threads only spin against the
    pipeline's own worker processes and the other nodes: `walker-gait process` on a 10 s session took
    11-12.5 s with OpenBLAS's default threads and 9.2-9.7 s with one, on the 2-core machine.
    """
    import os

    for name in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
        os.environ.setdefault(name, "1")
