"""A self-contained ``report.html`` from ``report.md``: figures embedded as base64.

The converter covers the markdown the report writes (headings, paragraphs, bullet
lists, pipe tables with ``\\|`` for a bar inside a cell, inline code, bold, images), so
no markdown package is needed. Wide tables scroll inside their own box; figures shrink
to the page's width.
"""

from __future__ import annotations

import base64
import html
import re
from pathlib import Path

_STYLE = """
body { font-family: system-ui, sans-serif; max-width: 1100px; margin: 2em auto;
       padding: 0 1em; color: #222; line-height: 1.45; }
table { border-collapse: collapse; margin: 1em 0; font-size: 0.9em; }
th, td { border: 1px solid #ccc; padding: 0.25em 0.6em; text-align: right; }
th { background: #f3f3f3; } td:first-child, th:first-child { text-align: left; }
code { background: #f5f5f5; padding: 0 0.2em; } img { max-width: 100%; height: auto; }
div.table { max-width: 100%; overflow-x: auto; }
"""


def _inline(text: str) -> str:
    out = html.escape(text, quote=False)
    out = re.sub(r"`([^`]+)`", r"<code>\1</code>", out)
    return re.sub(r"\*\*([^*]+)\*\*", r"<strong>\1</strong>", out)


def split_row(row: str) -> list[str]:
    """The cells of a markdown table row, split at unescaped ``|`` (``\\|`` is a bar
    inside a cell)."""
    body = row.strip()
    body = body[1:] if body.startswith("|") else body
    body = body[:-1] if body.endswith("|") and not body.endswith("\\|") else body
    return [c.strip().replace("\\|", "|") for c in re.split(r"(?<!\\)\|", body)]


def _image(alt: str, src: str, base: Path) -> str:
    path = base / src
    if not path.exists():
        return f"<p>[missing figure {html.escape(src)}]</p>"
    data = base64.b64encode(path.read_bytes()).decode()
    return f'<p><img alt="{html.escape(alt)}" src="data:image/png;base64,{data}"></p>'


def markdown_to_html(md: str, base: Path, title: str = "truthbench report") -> str:
    """Convert the report's markdown to one HTML page; images under ``base``."""
    lines = md.splitlines()
    body: list[str] = []
    i = 0
    while i < len(lines):
        line = lines[i]
        if not line.strip():
            i += 1
            continue
        m = re.match(r"^(#{1,6}) (.*)$", line)
        if m:
            n = len(m.group(1))
            body.append(f"<h{n}>{_inline(m.group(2))}</h{n}>")
            i += 1
            continue
        m = re.match(r"^!\[([^\]]*)\]\(([^)]+)\)\s*$", line)
        if m:
            body.append(_image(m.group(1), m.group(2), base))
            i += 1
            continue
        if line.startswith("|"):
            rows = []
            while i < len(lines) and lines[i].startswith("|"):
                rows.append(lines[i])
                i += 1
            cells = [split_row(r) for r in rows]
            head, data = cells[0], [r for r in cells[1:] if not set("".join(r)) <= set("-: ")]
            out = ["<table><tr>" + "".join(f"<th>{_inline(c)}</th>" for c in head) + "</tr>"]
            out += ["<tr>" + "".join(f"<td>{_inline(c)}</td>" for c in r) + "</tr>"
                    for r in data]
            body.append('<div class="table">' + "\n".join(out) + "</table></div>")
            continue
        if line.startswith("- "):
            items = []
            while i < len(lines) and lines[i].startswith("- "):
                items.append(f"<li>{_inline(lines[i][2:])}</li>")
                i += 1
            body.append("<ul>" + "".join(items) + "</ul>")
            continue
        para = []
        while i < len(lines) and lines[i].strip() and not re.match(r"^(#|\||- |!\[)", lines[i]):
            para.append(lines[i])
            i += 1
        body.append(f"<p>{_inline(' '.join(para))}</p>")
    return (f"<!DOCTYPE html>\n<html><head><meta charset='utf-8'><title>"
            f"{html.escape(title)}</title><style>{_STYLE}</style></head><body>\n"
            + "\n".join(body) + "\n</body></html>\n")


def write_html(report_md: Path) -> Path:
    """Write ``report.html`` beside ``report.md``."""
    report_md = Path(report_md)
    text = report_md.read_text(encoding="utf-8")
    title = text.splitlines()[0].lstrip("# ") if text else "truthbench report"
    out = report_md.with_suffix(".html")
    out.write_text(markdown_to_html(text, report_md.parent, title), encoding="utf-8")
    return out
