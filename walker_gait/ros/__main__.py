"""``python -m walker_gait.ros NODE [--ros-args ...]``: start one walker_gait node (used by ``walker-gait run``)."""

from __future__ import annotations

import sys

from walker_gait import limit_blas_threads

limit_blas_threads()


def main(argv: list[str] | None = None) -> int:
    args = list(sys.argv[1:] if argv is None else argv)
    from walker_gait.ros.nodes import NODES, _main

    if not args or args[0] not in NODES:
        print(f"usage: python -m walker_gait.ros {{{','.join(NODES)}}} [--ros-args ...]", file=sys.stderr)
        return 2
    name = args.pop(0)
    sys.argv = [name, *args]
    return _main(NODES[name])


if __name__ == "__main__":
    sys.exit(main())
