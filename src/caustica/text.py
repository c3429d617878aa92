"""Docstrings as the command line prints them: a first paragraph whole, without reStructuredText markup."""
from __future__ import annotations

import re

_ROLE = re.compile(r":[a-z]+:`(~[\w.]*\.)?([^`]+)`")  # :func:`name`, :class:`~a.b.C` (shown as C)
_LITERAL = re.compile(r"``([^`]+)``")


def plain(text: str) -> str:
    """``text`` with RST roles and double-backtick literals reduced to their words."""
    return _LITERAL.sub(r"\1", _ROLE.sub(r"\2", text))


def summary(doc: str | None) -> str:
    """A docstring's first paragraph on one line, as plain text: a wrapped first line alone stops mid-sentence."""
    paragraph = (doc or "").strip().split("\n\n")[0]
    return plain(" ".join(paragraph.split()))
