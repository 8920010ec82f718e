"""shown_text.py owns every text shown to people: Markdown is `Markdown`, which only it escapes,
HTML is its auto-escaping Jinja2, links are parsed; no other module goes around it."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

import odms_data
from odms_data.shown_text import Markdown, html, markdown, markdown_link, web_link, yaml_header

PACKAGE = Path(odms_data.__file__).resolve().parent


def test_a_field_that_is_not_markdown_is_escaped():
    hostile = "x | y <script>alert(1)</script> [a](javascript:b)\n| 1 |"
    out = markdown("| {name} | {link} |", name=hostile, link=markdown_link("n", "https://e.org"))
    assert out == ("| x \\| y &lt;script&gt;alert(1)&lt;/script&gt; \\[a\\]\\(javascript:b) \\| 1 \\| "
                   "| [n](https://e.org) |")
    assert isinstance(out, Markdown) and markdown("{n:,}", n=12345) == "12,345"


@pytest.mark.parametrize("url", ["https://[::1", "https://", "javascript:alert(1)", "ftp://e.org",
                                 "https://e.org:99999", "https://e.org/\n", None, 3])
def test_web_link_refuses_what_urllib_does_not_read_as_http(url):
    assert web_link(url) is None


def test_web_link_keeps_http_addresses_and_encodes_what_would_end_them():
    assert web_link("https://[::1]:8080/a b") == "https://[::1]:8080/a%20b"
    assert web_link('http://e.org/"><script>') == "http://e.org/%22%3E%3Cscript%3E"


def test_html_escapes_every_field_and_links_only_http():
    page = html('<a href="{{ u | link }}">{{ name }}</a>{% if v | link %}x{% endif %}',
                name="<script>alert(1)</script>", u="https://e.org/?a=1&b=2", v="javascript:x")
    assert page == '<a href="https://e.org/?a=1&amp;b=2">&lt;script&gt;alert(1)&lt;/script&gt;</a>'


def test_a_yaml_header_value_cannot_end_the_header():
    import yaml

    out = yaml_header({"pretty_name": "<b>a\n---\nlicense: mit", "tags": ["x"]})
    assert out == '---\npretty_name: "\\u003cb\\u003ea\\n---\\nlicense: mit"\ntags:\n  - "x"\n---\n'
    assert yaml.safe_load(out.split("---\n")[1]) == {"pretty_name": "<b>a\n---\nlicense: mit", "tags": ["x"]}
    link_and_row = "[x](javascript:y) | b\n|---|---|"
    out = yaml_header({"pretty_name": link_and_row})  # no markup for a reader that shows it raw
    assert "](javascript:" not in out and "|---|" not in out
    assert yaml.safe_load(out.split("---\n")[1]) == {"pretty_name": link_and_row}


def _modules():
    for path in sorted(PACKAGE.rglob("*.py")):
        if path.name != "shown_text.py":
            yield path, ast.parse(path.read_text(), str(path))


def test_no_module_renders_around_the_owner():
    """Only shown_text imports a template engine or markupsafe, and any other module makes
    `Markdown` only from a string literal of its own (a citation in code, say)."""
    for path, tree in _modules():
        for node in ast.walk(tree):
            if isinstance(node, ast.Import | ast.ImportFrom):
                names = [a.name for a in node.names] + ([node.module] if isinstance(node, ast.ImportFrom)
                                                        and node.module else [])
                assert not any(n.split(".")[0] in ("jinja2", "markupsafe", "mako") for n in names), path
            if isinstance(node, ast.Call) and getattr(node.func, "id", None) == "Markdown":
                arg = node.args[0] if node.args else None
                literal = isinstance(arg, ast.Constant) and isinstance(arg.value, str)
                assert literal, f"{path}:{node.lineno} wraps text that is not a literal in Markdown"
