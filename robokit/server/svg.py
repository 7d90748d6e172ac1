"""SVG plots are stored re-serialised from a parse, never as sent.

The upload is parsed by lxml (libxml2: namespaces resolved, no network, no entity expansion; a DTD internal subset
is refused outright). A new document is then built from what an SVG plot needs - drawing elements and presentation
attributes on an allowlist - and written out. Because names are compared after namespace resolution, a prefixed
``<s:script xmlns:s="http://www.w3.org/2000/svg">`` is the SVG ``script`` element and is dropped like a plain one;
because values are compared after the parser has decoded character references, ``javascript&#58;`` is seen as
``javascript:``. Links may only point inside the document (``#id``); an ``<image>`` may only carry an embedded PNG
or JPEG (as matplotlib writes them); CSS may not load anything (``url()`` only to ``#id``, no ``@import``, no
escapes). What is not on the lists - scripts, event handlers, ``foreignObject``, animation, ``<a>``, metadata,
comments, processing instructions - is simply not copied.
"""

from __future__ import annotations

import re
from typing import Any

SVG_NS = "http://www.w3.org/2000/svg"
XLINK_NS = "http://www.w3.org/1999/xlink"
XML_NS = "http://www.w3.org/XML/1998/namespace"

ELEMENTS = frozenset("""
svg g defs symbol use path rect circle ellipse line polyline polygon text tspan textPath title desc clipPath
mask pattern linearGradient radialGradient stop marker image style switch
""".split())
TEXT_ELEMENTS = frozenset({"text", "tspan", "textPath", "title", "desc", "style"})
ATTRIBUTES = frozenset("""
id class style transform d x y x1 y1 x2 y2 cx cy r rx ry fx fy width height points viewBox preserveAspectRatio
version baseProfile fill fill-opacity fill-rule stroke stroke-width stroke-linecap stroke-linejoin
stroke-miterlimit stroke-dasharray stroke-dashoffset stroke-opacity opacity clip-path clip-rule clipPathUnits mask
maskUnits maskContentUnits patternUnits patternContentUnits patternTransform gradientUnits gradientTransform offset
stop-color stop-opacity spreadMethod font-family font-size font-weight font-style font-variant text-anchor
dominant-baseline alignment-baseline baseline-shift letter-spacing word-spacing dx dy rotate textLength lengthAdjust
startOffset visibility display color marker-start marker-mid marker-end markerWidth markerHeight markerUnits refX
refY orient overflow vector-effect shape-rendering text-rendering image-rendering color-interpolation
color-interpolation-filters paint-order type
""".split())
HREFS = ("href", f"{{{XLINK_NS}}}href")
IMAGE_DATA = re.compile(r"^data:image/(png|jpeg);base64,[A-Za-z0-9+/=\s]*$")
_URL = re.compile(r"url\s*\(", re.I)
_LOCAL_URL = re.compile(r"url\s*\(\s*['\"]?#[A-Za-z0-9_.:-]*['\"]?\s*\)", re.I)
_CSS_DANGER = re.compile(r"[\\@<]|expression|javascript|behavior|binding", re.I)
_SCHEME = re.compile(r"(javascript|vbscript|data):", re.I)
_INTERNAL_SUBSET = re.compile(rb"<!DOCTYPE[^>\[]*\[|<!ENTITY", re.I)


class SvgError(ValueError):
    """Not a well-formed SVG image (the message says why, in one line)."""


def clean_svg(raw: bytes) -> bytes:
    """The SVG in ``raw`` rebuilt from the allowlists above, as UTF-8 XML.

    Raises:
        SvgError: not well-formed XML, a DTD internal subset (entities), or a root that is not ``<svg>``.
    """
    from lxml import etree  # the server extra; imported here so `robokit --help` never pays for it

    if _INTERNAL_SUBSET.search(raw):
        raise SvgError("declares a DTD internal subset or entities; a plot needs neither")
    parser = etree.XMLParser(resolve_entities=False, no_network=True, load_dtd=False, remove_comments=True,
                             remove_pis=True, huge_tree=False)
    try:
        root = etree.fromstring(raw, parser)
    except etree.XMLSyntaxError as exc:
        raise SvgError(f"is not well-formed XML ({exc})") from None
    if _local(root) != "svg":
        raise SvgError("is not an SVG image (its root element is not <svg>)")
    out = etree.Element(f"{{{SVG_NS}}}svg", nsmap={None: SVG_NS, "xlink": XLINK_NS})
    _copy(root, out)
    data: bytes = etree.tostring(out, xml_declaration=True, encoding="UTF-8")
    return data


def _local(element: Any) -> str | None:
    """The element's SVG name (``"rect"``), or None when it is not in the SVG namespace (nor in none)."""
    if not isinstance(element.tag, str):  # a comment, processing instruction or entity reference
        return None
    namespace, _, local = element.tag[1:].partition("}") if element.tag.startswith("{") else ("", "", element.tag)
    return local if namespace in ("", SVG_NS) else None


def _copy(source: Any, target: Any) -> None:
    """Copy ``source``'s allowed attributes, text and allowed children (recursively) onto ``target``."""
    from lxml import etree

    name = _local(source)
    for key, value in source.attrib.items():
        kept = _attribute(name, key, value)
        if kept is not None:
            target.set(kept, value)
    if name in TEXT_ELEMENTS and source.text and (name != "style" or _css_ok(source.text)):
        target.text = source.text
    for child in source:
        local = _local(child)
        if local not in ELEMENTS:
            continue
        if local == "style" and not _css_ok(child.text or ""):
            continue
        copy = etree.SubElement(target, f"{{{SVG_NS}}}{local}")
        _copy(child, copy)
        if child.tail and name in TEXT_ELEMENTS:
            copy.tail = child.tail


def _attribute(element: str | None, key: str, value: str) -> str | None:
    """The name to write the attribute under, or None to drop it."""
    if key in HREFS:
        ok = IMAGE_DATA.match(value.strip()) if element == "image" else value.strip().startswith("#")
        return f"{{{XLINK_NS}}}href" if ok and key != "href" else ("href" if ok else None)
    if key == f"{{{XML_NS}}}space":
        return key
    if key not in ATTRIBUTES:
        return None
    if key == "style":
        return key if _css_ok(value) else None
    squeezed = re.sub(r"[\s\x00-\x1f]", "", value)
    if _SCHEME.search(squeezed) or len(_URL.findall(value)) != len(_LOCAL_URL.findall(value)):
        return None
    return key


def _css_ok(css: str) -> bool:
    """CSS that can only style: no escapes, at-rules, markup or legacy script hooks, ``url()`` only to ``#id``."""
    if _CSS_DANGER.search(css):
        return False
    return len(_URL.findall(css)) == len(_LOCAL_URL.findall(css))
