"""No page builds HTML from data (issue 25 item 5): a static check of the web apps' JavaScript.

Files dropped on a page, broker messages and API answers are untrusted; the pages put them on
the page as text nodes (``ui.el``, ``textContent``). This fails, listing them, on every place that
would parse a string as HTML from something other than a literal:

- ``innerHTML =`` / ``outerHTML =`` / ``+=``, ``insertAdjacentHTML``, ``document.write``,
  ``createContextualFragment``, ``DOMParser``;
- Leaflet's string-to-HTML calls (``bindTooltip``, ``bindPopup``, ``setTooltipContent``,
  ``setPopupContent``, ``setContent``, ``divIcon({html})``): their content must be a DOM node
  (``el(...)``, a name bound to ``el(...)`` or ``document.createElement(...)`` in the same file)
  or a string literal without ``${...}``.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

WEB_JS = Path(__file__).resolve().parents[2] / "src" / "dronefleet" / "web" / "js"

#: Sinks whose right side (or argument) must be a literal.
_ASSIGNED = re.compile(r"\.(?:innerHTML|outerHTML)\s*\+?=(?!=)")
_CALLED = re.compile(
    r"\b(?:insertAdjacentHTML|document\.write(?:ln)?|createContextualFragment)\s*\("
)
_PARSER = re.compile(r"\bnew\s+DOMParser\b")
#: Leaflet calls that insert a string content as HTML (a node is appended as it is).
_LEAFLET = re.compile(
    r"\.(?:bindTooltip|bindPopup|setTooltipContent|setPopupContent|setContent)\s*\("
)
_DIV_ICON_HTML = re.compile(r"\bdivIcon\s*\(\s*\{[^}]*?\bhtml\s*:")
_LITERAL = re.compile(r"""^(?:"(?:[^"\\\n]|\\.)*"|'(?:[^'\\\n]|\\.)*'|`[^`$]*`)$""")


def _expression(text: str, start: int) -> str:
    """The expression beginning at ``start``, up to a ``,`` ``;`` ``)`` ``}`` or end of line
    outside brackets and strings."""
    depth, i, quote = 0, start, ""
    while i < len(text):
        c = text[i]
        if quote:
            if c == "\\":
                i += 1
            elif c == quote:
                quote = ""
        elif c in "\"'`":
            quote = c
        elif c in "([{":
            depth += 1
        elif c in ")]}":
            if depth == 0:
                break
            depth -= 1
        elif c in ",;\n" and depth == 0:
            break
        i += 1
    return text[start:i].strip()


def _nodes(text: str) -> set[str]:
    """Names this file binds to a DOM node it builds."""
    found = re.findall(r"\b(?:const|let|var)\s+(\w+)\s*=\s*(?:el|document\.createElement)\(", text)
    return set(found)


def _safe(expression: str, nodes: set[str]) -> bool:
    if _LITERAL.match(expression):
        return True
    if re.match(r"^el\(", expression):
        return True
    return expression in nodes


def html_from_data(text: str) -> list[str]:
    """Each place in ``text`` (a JavaScript file) that would parse a non-literal as HTML."""
    nodes = _nodes(text)
    found = []

    def line_of(at: int) -> str:
        number = text.count("\n", 0, at) + 1
        return f"{number}: {text.splitlines()[number - 1].strip()}"

    for match in _ASSIGNED.finditer(text):
        if not _LITERAL.match(_expression(text, match.end())):
            found.append(line_of(match.start()))
    for pattern in (_CALLED, _PARSER):
        found += [line_of(m.start()) for m in pattern.finditer(text)]
    for pattern in (_LEAFLET, _DIV_ICON_HTML):
        for match in pattern.finditer(text):
            if not _safe(_expression(text, match.end()), nodes):
                found.append(line_of(match.start()))
    return found


def test_no_web_page_builds_html_from_data():
    sources = sorted(WEB_JS.rglob("*.js"))
    assert len(sources) > 10, WEB_JS  # the pages are there
    offending = {
        str(path.relative_to(WEB_JS)): places
        for path in sources
        if (places := html_from_data(path.read_text()))
    }
    assert offending == {}, "HTML built from data (use el()/textContent):\n" + "\n".join(
        f"  {name}:{place}" for name, places in offending.items() for place in places
    )


@pytest.mark.parametrize(
    "line",
    [
        "box.innerHTML = log.name;",
        "box.innerHTML += `<b>${d.drone_id}</b>`;",
        "row.outerHTML = html",
        "list.insertAdjacentHTML('beforeend', item);",
        "marker.bindTooltip(d.drone_id, { permanent: true });",
        "marker.bindPopup(`<b>${name}</b>`);",
        "tip.setContent(text)",
        "L.divIcon({ className: 'x', html: `<span>${d.drone_id}</span>` })",
        "const doc = new DOMParser().parseFromString(text, 'text/html');",
    ],
)
def test_the_check_finds_html_built_from_data(line):
    assert html_from_data(line + "\n")


@pytest.mark.parametrize(
    "line",
    [
        'box.innerHTML = "";',
        "box.textContent = log.name;",
        "if (a.innerHTML === b) x();",
        'marker.bindTooltip("you").addTo(map);',
        'marker.bindTooltip(el("span", {}, d.drone_id), { permanent: true });',
        "const label = el('span', {}, name);\nmarker.bindTooltip(label);",
        "const root = document.createElement('div');\nL.divIcon({ html: root, iconSize: [1, 1] });",
    ],
)
def test_the_check_lets_text_nodes_and_literals_pass(line):
    assert html_from_data(line + "\n") == []
