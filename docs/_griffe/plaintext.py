"""Griffe extension for the API reference: render jaxlpm's free-form docstrings readably.

jaxlpm's docstrings are plain text, not Google/NumPy sections (mkdocs.yml sets
`docstring_style: null`). Most paragraphs are prose and read well as Markdown, but many lay
things out in columns: field lists ("orbit        the chief's KeplerOrbit"), formulas
("minimise  J = 1/2 int |u|^2 dt"), tables of stats with hanging indents. Markdown would run
those lines together into one paragraph, so this extension rewrites each docstring, a
paragraph (blank-line separated) at a time, before rendering:

- a paragraph laid out by spaces (a gap of two or more spaces inside a line, or an indented
  line) becomes a fenced ```text block, kept as written;
- a Markdown table (every line starts with "|") or list ("- ", "* ", "1. ") stays one;
- in a prose paragraph (tables and lists too), a line that starts a "name: description" item (`grid: a Grid ...`,
  `throw: ...`) after a line that ends a clause starts a new line instead of continuing
  the sentence before it, and `_`, `*`, `[` and `<` outside code spans are literal (x_i,
  J*, x[0][1], <case> are formulas and placeholders, not emphasis, links or HTML).

Only the rendered text changes; the source docstrings stay as they are.
"""

import re

import griffe

_LIST = re.compile(r"^(?:[-*+]|\d+[.)])\s")
_GAP = re.compile(r"\S {2,}\S")
_ITEM = re.compile(r"^`?[A-Za-z_][\w.\[\]\"']*`?(?:, `?[A-Za-z_][\w.]*`?)*:\s")
_CODE = re.compile(r"(`+).*?\1", re.S)                  # a code span, left as it is
_STAR = re.compile(r"(?<!^)(?<!\n)\*|\*(?! )")              # not a "* item" list marker
_EMPHASIS = re.compile(r"(?<![\w*])\*\w[^*\n]*?\w\*(?![\w*])")   # *word*, meant as such


def _escape(text):
    """Formula characters that Markdown would take for markup, made literal: `_` (x_i), `*`
    (J*, a * b; a deliberate *word* stays emphasis), `[` (x[0][1] is no cross-reference)
    and `<` (`<case>` is not an HTML tag)."""
    def plain(part):
        kept = _EMPHASIS.findall(part)
        pieces = _EMPHASIS.split(part)
        pieces = [_STAR.sub(r"\\*", p.replace("_", "\\_").replace("[", "\\["))
                  .replace("<", "&lt;") for p in pieces]
        return "".join(p + (kept[i] if i < len(kept) else "") for i, p in enumerate(pieces))

    out, last = [], 0
    for code in _CODE.finditer(text):
        out += [plain(text[last:code.start()]), code.group(0)]
        last = code.end()
    return "".join(out + [plain(text[last:])])


def _is_layout(lines):
    if all(line.lstrip().startswith("|") for line in lines):
        return False                                    # a Markdown table
    if _LIST.match(lines[0]):
        return False                                    # a Markdown list
    return (any(_GAP.search(line) for line in lines)
            or any(line[:1] == " " for line in lines))


def _prose(lines):
    out = _escape("\n".join(lines)).split("\n")
    for i in range(1, len(out)):
        if _ITEM.match(lines[i]) and lines[i - 1].endswith((".", ";", ":", ")")):
            out[i - 1] = out[i - 1] + "  "              # Markdown hard line break
    return out


def to_markdown(text: str) -> str:
    """The docstring `text` with laid-out paragraphs fenced and item lines broken."""
    out, para, fenced = [], [], False

    def flush():
        if para:
            if _is_layout(para):
                out.append("```text\n" + "\n".join(para) + "\n```")
            else:
                out.append("\n".join(_prose(para)))
            para.clear()

    for line in text.splitlines():
        if line.lstrip().startswith("```"):              # a fenced block: kept as written
            flush()
            fenced = not fenced
            out.append(line)
        elif fenced:
            out.append(line)
        elif line.strip():
            para.append(line.rstrip())
        else:
            flush()
            out.append("")
    flush()
    return "\n".join(out)


class PlainTextDocstrings(griffe.Extension):
    """Rewrite every docstring with `to_markdown` once the package is loaded."""

    def on_object(self, *, obj, **kwargs) -> None:
        if obj.docstring is not None and not getattr(obj, "_jaxlpm_plaintext", False):
            obj.docstring.value = to_markdown(obj.docstring.value)
            obj._jaxlpm_plaintext = True
