"""Accessibility helpers for the browser tests: axe-core (from npm) and the WCAG contrast ratio.

axe-core is a devDependency (package.json); it is read from ``node_modules`` and evaluated in the
page by the test, so the app never ships it and its CSP (scripts only from the server) stays on:
``page.evaluate`` runs through the DevTools protocol, which a page's CSP does not govern.
"""

from __future__ import annotations

import re
from typing import Any

import pytest

from .conftest import ROOT

AXE = ROOT / "node_modules" / "axe-core" / "axe.min.js"
#: The impacts that fail a page (axe's four levels: minor, moderate, serious, critical).
BLOCKING = {"serious", "critical"}


def axe_source() -> str:
    if not AXE.exists():
        pytest.fail(f"axe-core is missing ({AXE}): run scripts/web-deps.sh (npm ci)")
    return AXE.read_text()


def run_axe(page: Any) -> list[dict[str, Any]]:
    """axe's violations on the page as it is now (WCAG 2.0/2.1 A and AA, and best practices)."""
    if not page.evaluate("() => typeof window.axe === 'object'"):
        page.evaluate(axe_source())
    return page.evaluate(
        """async () => {
             const r = await axe.run(document, {resultTypes: ['violations']});
             return r.violations.map((v) => ({id: v.id, impact: v.impact, help: v.help,
               nodes: v.nodes.map((n) => ({target: n.target.join(' '),
                                           summary: n.failureSummary}))}));
           }"""
    )


def blocking(violations: list[dict[str, Any]]) -> list[dict[str, Any]]:
    return [v for v in violations if v["impact"] in BLOCKING]


def describe(violations: list[dict[str, Any]]) -> str:
    lines = []
    for v in violations:
        lines.append(f"{v['impact']} {v['id']}: {v['help']}")
        lines += [f"    {n['target']}: {n['summary']}" for n in v["nodes"][:5]]
    return "\n".join(lines)


# -- WCAG 2.x contrast -----------------------------------------------------------------------------
_RGB = re.compile(r"rgba?\(([\d.]+),\s*([\d.]+),\s*([\d.]+)(?:,\s*([\d.]+))?\)")


def parse_rgb(css: str) -> tuple[float, float, float, float]:
    """A computed CSS colour (``rgb(r, g, b)`` or ``rgba(r, g, b, a)``) as (r, g, b, alpha)."""
    match = _RGB.fullmatch(css.strip())
    if not match:
        raise ValueError(f"not a computed rgb colour: {css!r}")
    r, g, b, a = match.groups()
    return float(r), float(g), float(b), float(a) if a is not None else 1.0


def relative_luminance(rgb: tuple[float, float, float]) -> float:
    """WCAG 2.x relative luminance of an sRGB colour (0-255 channels)."""

    def linear(channel: float) -> float:
        c = channel / 255.0
        return c / 12.92 if c <= 0.04045 else ((c + 0.055) / 1.055) ** 2.4

    r, g, b = (linear(c) for c in rgb)
    return 0.2126 * r + 0.7152 * g + 0.0722 * b


def contrast_ratio(fg: str, bg: str) -> float:
    """(L1 + 0.05) / (L2 + 0.05) of two opaque computed colours, lighter over darker."""
    *f, fa = parse_rgb(fg)
    *b, ba = parse_rgb(bg)
    if fa < 1 or ba < 1:
        raise ValueError(f"translucent colours need the backdrop: {fg} on {bg}")
    hi, lo = sorted((relative_luminance(tuple(f)), relative_luminance(tuple(b))), reverse=True)
    return (hi + 0.05) / (lo + 0.05)
