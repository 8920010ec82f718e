"""Text that came from data, made safe to show a person: on a terminal, in Markdown and in HTML.

An id, a source, a leaderboard name or citation, an export's title or licence may come from a
stranger's file or argument. On a terminal its control characters (escape sequences set the
window title, write the clipboard, move the cursor) are shown as `\\x1b`-style escapes
(`for_terminal`). Markdown and HTML are rendered only here, and a renderer cannot take raw text:

- Markdown is `Markdown`, text already safe: `markdown_text` escapes `|`, HTML and link syntax
  onto one line, `markdown_link` keeps a link only for an http(s) address, and `markdown(template,
  **fields)` fills odms-data's own template escaping every field that is not `Markdown` already
  (`markdown_join` joins parts so);
  `yaml_header` writes a card's header with every scalar quoted.
- HTML is Jinja2's, auto-escaping every value (`html`); its `link` filter keeps only http(s).

A link is parsed (urllib.parse), never pattern-matched (`web_link`). Emphasis is left alone in
Markdown: it harms nothing, and names such as ODN_d stay readable in the Markdown source. This
module is the one place these rules are written.
"""

from __future__ import annotations

import json
import re
import string
import unicodedata
from collections.abc import Iterable, Mapping
from functools import cache
from typing import Any
from urllib.parse import quote, urlsplit

_UNSAFE = ("Cc", "Cf", "Cs", "Co", "Cn", "Zl", "Zp")  # controls, format (bidi), unassigned, line breaks
# what makes a cell end, a link, HTML or an entity (a `(` after `]`: the link's target, escaped too)
_MARKDOWN = re.compile(r"([\\|\[\]<>]|&(?=#?\w+;)|(?<=\])\()")


class Markdown(str):
    """Text that is safe in Markdown. Made by this module's functions, or from a literal of
    odms-data's own (tests/test_shown_text.py checks no other module wraps anything else)."""


def _escape(c: str) -> str:
    n = ord(c)
    return f"\\x{n:02x}" if n < 0x100 else f"\\u{n:04x}" if n < 0x10000 else f"\\U{n:08x}"


def for_terminal(text: object) -> str:
    """`text` with every control, format and line-breaking character written as an escape."""
    s = str(text)
    if s.isprintable():
        return s
    return "".join(_escape(c) if unicodedata.category(c) in _UNSAFE else c for c in s)


def one_line(text: object) -> str:
    """`text` with its runs of white space (line breaks included) as single spaces, trimmed."""
    return " ".join(str(text).split())


def markdown_text(text: object) -> Markdown:
    """`text` as inert Markdown on one line: no table cell break, no HTML, no link, no emphasis."""
    s = for_terminal(one_line(text))
    entity = {"<": "&lt;", ">": "&gt;", "&": "&amp;"}
    return Markdown(_MARKDOWN.sub(lambda m: entity.get(m[1], "\\" + m[1]), s))


def web_link(url: object) -> str | None:
    """`url` when urllib.parse reads it as an http(s) address with a host, its unsafe characters
    percent-encoded; else None (another scheme, no host, a malformed address such as `https://[::1`)."""
    if not isinstance(url, str) or not url.isprintable():
        return None
    try:
        parts = urlsplit(url)
        host, _ = parts.hostname, parts.port  # a bad IPv6 literal or port raises here
    except ValueError:
        return None
    if parts.scheme not in ("http", "https") or not host:
        return None
    return quote(url, safe=":/?#@!$&*+,;=%~-._[]")


def markdown_link(text: object, url: object) -> Markdown:
    """A Markdown link to `url` when it is an http(s) address (`web_link`), else `text` alone;
    `text` escaped as `markdown_text` does."""
    label, link = markdown_text(text), web_link(url)
    return Markdown(f"[{label}]({link})") if link else label


class _MarkdownFields(string.Formatter):
    def format_field(self, value: Any, format_spec: str) -> str:
        s = super().format_field(value, format_spec)
        return s if isinstance(value, Markdown) else markdown_text(s)


def markdown(template: str, /, **fields: object) -> Markdown:
    """`template`, odms-data's own text, with its `{name}` fields filled: a `Markdown` field as it
    is, any other formatted and then escaped as `markdown_text`."""
    return Markdown(_MarkdownFields().vformat(template, (), fields))


def markdown_join(separator: str, parts: Iterable[object]) -> Markdown:
    """`parts` joined by `separator` (odms-data's own), each escaped unless it is Markdown already."""
    return Markdown(separator.join(p if isinstance(p, Markdown) else markdown_text(p) for p in parts))


_HEADER_MARKUP = {c: f"\\u{ord(c):04x}" for c in "<>&[]|"}


def _quoted(value: object) -> str:
    """A YAML double-quoted scalar (JSON's), with `<`, `>`, `&`, `[`, `]` and `|` as \\u escapes too: a
    reader that shows the header as HTML or Markdown without parsing it meets no markup (no tag, link
    or table row)."""
    return "".join(_HEADER_MARKUP.get(c, c) for c in json.dumps(value))


def _yaml(value: object, indent: int) -> str:
    pad = " " * indent
    if isinstance(value, Mapping):
        return "\n".join(f"{pad}{k}:\n{_yaml(v, indent + 2)}" if isinstance(v, Mapping | list)
                         else f"{pad}{k}: {_quoted(v)}" for k, v in value.items())
    if isinstance(value, list):
        items = (_yaml(v, indent + 2)[indent + 2:] if isinstance(v, Mapping) else _quoted(v) for v in value)
        return "\n".join(f"{pad}- {item}" for item in items)
    return f"{pad}{_quoted(value)}"


def yaml_header(fields: Mapping[str, object]) -> Markdown:
    """A Markdown file's YAML header between `---` lines: mappings, lists, and scalars quoted
    (ASCII, one line each, no markup), so no value can end the header, start a key or show as HTML."""
    if any(not re.fullmatch(r"[a-z_]+", k) for k in fields):
        raise ValueError("YAML header keys are odms-data's own identifiers")
    return Markdown(f"---\n{_yaml(fields, 0)}\n---\n")


@cache
def _html_environment():
    import jinja2

    env = jinja2.Environment(autoescape=True, undefined=jinja2.StrictUndefined, trim_blocks=True,
                             lstrip_blocks=True)
    env.filters["link"] = web_link
    return env


def html(template: str, /, **fields: object) -> str:
    """`template`, odms-data's own Jinja2 text, rendered with every field HTML-escaped; its `link`
    filter gives an http(s) address or None (`web_link`)."""
    return _html_environment().from_string(template).render(**fields)
