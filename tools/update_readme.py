"""Regenerate the README sections that are derived from code (parameters, metric definitions).

``python tools/update_readme.py`` rewrites them; ``--check`` exits 1 if the README is out of date
(the test suite runs the check).
"""

from __future__ import annotations

import re
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))


def sections() -> dict[str, str]:
    from walker_gait.paramspec import markdown_table

    out = {"params": markdown_table()}
    metrics = ROOT / "docs" / "GAIT_METRICS.md"
    if metrics.is_file():
        text = metrics.read_text(encoding="utf-8").strip()
        text = re.sub(r"^# .*\n+", "", text)  # drop the document title
        out["metrics"] = re.sub(r"^(#+) ", r"#\1 ", text, flags=re.M)  # nest one level deeper
    return out


def render(readme: str) -> str:
    for name, body in sections().items():
        pattern = re.compile(rf"(<!-- {name}:begin -->\n).*?(<!-- {name}:end -->)", re.S)
        readme = pattern.sub(lambda m: m.group(1) + body + "\n" + m.group(2), readme)
    return readme


def main() -> int:
    path = ROOT / "README.md"
    current = path.read_text(encoding="utf-8")
    new = render(current)
    if "--check" in sys.argv:
        if new != current:
            print("README.md is out of date: run `python tools/update_readme.py`", file=sys.stderr)
            return 1
        return 0
    path.write_text(new, encoding="utf-8")
    return 0


if __name__ == "__main__":
    sys.exit(main())
