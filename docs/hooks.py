"""MkDocs hook: the JSON schemas of grader/schemas/ shown on the site as they are shipped.

A page that says `<!-- schema: report.schema.json -->` on a line of its own gets that file's text there, as a
```json code block, read at build time: the site cannot drift from the schemas. A marker naming no schema fails
the build; a schema that no page shows is a warning, which `mkdocs build --strict` makes a failure.
"""

from __future__ import annotations

import logging
import re
from pathlib import Path

from mkdocs.exceptions import PluginError

SCHEMAS = Path(__file__).resolve().parents[1] / "grader" / "schemas"
MARKER = re.compile(r"^<!-- schema: (?P<name>[\w.-]+) -->$", re.MULTILINE)
log = logging.getLogger("mkdocs.hooks.schemas")
_shown: set[str] = set()


def _block(match: re.Match, page: str) -> str:
    name = match["name"]
    path = SCHEMAS / name
    if not path.is_file():
        raise PluginError(f"{page}: no schema {name!r} in grader/schemas/")
    _shown.add(name)
    text = path.read_text(encoding="utf-8").rstrip("\n")
    fence = "`" * max(3, 1 + max((len(run) for run in re.findall(r"`+", text)), default=0))
    return f"{fence}json\n{text}\n{fence}"


def on_pre_build(config) -> None:
    _shown.clear()


def on_page_markdown(markdown: str, page, config, files) -> str:
    return MARKER.sub(lambda match: _block(match, page.file.src_uri), markdown)


def on_post_build(config) -> None:
    for path in sorted(SCHEMAS.glob("*.json")):
        if path.name not in _shown:
            log.warning("the schema grader/schemas/%s is on no page: add `<!-- schema: %s -->` where it belongs",
                        path.name, path.name)
