"""The documentation pages as the docs tests read them."""

from __future__ import annotations

import re


def blocks(text: str) -> list[str]:
    """The ```python code blocks of a markdown text, in order."""
    return re.findall(r"^```python\n(.*?)^```$", text, flags=re.S | re.M)


def squash(text: str) -> str:
    """``text`` with every run of white space one blank (for phrases across lines)."""
    return " ".join(text.split())
