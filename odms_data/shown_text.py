"""Text that came from data, made safe to show a person: on a terminal, and in Markdown.

An id, a source, a leaderboard name or citation may come from a stranger's file. On a terminal
its control characters (escape sequences set the window title, write the clipboard, move the
cursor) are shown as `\\x1b`-style escapes (`for_terminal`); in a Markdown table its `|`, HTML and
link syntax are escaped, and a link is kept only for an http(s) address (`markdown_text`,
`markdown_link`). Emphasis is left alone: it harms nothing, and names such as ODN_d stay readable
in the Markdown source. This module is the one place these rules are written.
"""

from __future__ import annotations

import re
import unicodedata
from urllib.parse import quote, urlsplit

_UNSAFE = ("Cc", "Cf", "Cs", "Co", "Cn", "Zl", "Zp")  # controls, format (bidi), unassigned, line breaks
_MARKDOWN = re.compile(r"([\\|\[\]<>]|&(?=#?\w+;))")  # what makes a cell end, a link, HTML or an entity


def _escape(c: str) -> str:
    n = ord(c)
    return f"\\x{n:02x}" if n < 0x100 else f"\\u{n:04x}" if n < 0x10000 else f"\\U{n:08x}"


def for_terminal(text: object) -> str:
    """`text` with every control, format and line-breaking character written as an escape."""
    s = str(text)
    if s.isprintable():
        return s
    return "".join(_escape(c) if unicodedata.category(c) in _UNSAFE else c for c in s)


def markdown_text(text: object) -> str:
    """`text` as inert Markdown on one line: no table cell break, no HTML, no link, no emphasis."""
    s = for_terminal(" ".join(str(text).split()))
    return _MARKDOWN.sub(lambda m: {"<": "&lt;", ">": "&gt;", "&": "&amp;"}.get(m[1], "\\" + m[1]), s)


def markdown_link(text: object, url: str | None) -> str:
    """A Markdown link to `url` when it is an http(s) address (its unsafe characters
    percent-encoded), else `text` alone; `text` escaped as `markdown_text` does."""
    label = markdown_text(text)
    parts = urlsplit(url or "")
    if parts.scheme not in ("http", "https") or not parts.netloc:
        return label
    return f"[{label}]({quote(url or '', safe=':/?#@!$&*+,;=%~-._')})"
