"""Help text for a config dataclass's fields, read from the comments beside and above each field.

The configs document their fields with comments (the saved ``config.json`` is the run's record, the source is
its documentation); the command line shows the same words under ``--help`` instead of a bare default.
"""

from __future__ import annotations

import ast
import inspect
import io
import textwrap
import tokenize


def field_help(config_cls: type) -> dict[str, str]:
    """{field name: its comment} for every field of ``config_cls`` that has one: the comment lines right above
    the field, then the comment at the end of its line(s)."""
    try:
        source = textwrap.dedent(inspect.getsource(config_cls))
    except (OSError, TypeError):  # no source (a frozen build): help without the comments
        return {}
    comments: dict[int, str] = {}
    code_lines: set[int] = set()
    for tok in tokenize.generate_tokens(io.StringIO(source).readline):
        if tok.type == tokenize.COMMENT:
            comments[tok.start[0]] = tok.string.lstrip("#").strip()
        elif tok.type not in (tokenize.NL, tokenize.NEWLINE, tokenize.INDENT, tokenize.DEDENT, tokenize.ENDMARKER):
            code_lines.add(tok.start[0])
    out = {}
    for node in ast.parse(source).body[0].body:  # type: ignore[attr-defined]
        if not (isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name)):
            continue
        above, line = [], node.lineno - 1
        while line in comments and line not in code_lines:  # a block of comment-only lines right above
            above.insert(0, comments[line])
            line -= 1
        beside = [comments[i] for i in range(node.lineno, (node.end_lineno or node.lineno) + 1) if i in comments]
        text = " ".join(above + beside).strip()
        if text:
            out[node.target.id] = text
    return out
