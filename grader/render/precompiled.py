"""The HTML report's templates as jinja2 compiles them, shipped as modules of grader.render.compiled (jinja2's
precompiled templates, loaded as its ModuleLoader loads them): a report then costs an import of the template's
module (its bytecode kept by Python, about 1 ms) instead of compiling the page's template (about 60 ms), on every
`grade --html`, first run included.

A shipped module is used only if it was compiled from exactly this template's text, with these options and this
jinja2 version (its DIGEST says so); otherwise the template is compiled in this process, as without it. After a
template changes, `python -m grader.render.html` writes the modules again (tests/render/test_html.py fails until then)."""

from __future__ import annotations

import hashlib
import importlib
from pathlib import Path

import jinja2

FOLDER = Path(__file__).with_name("compiled")
_OPTIONS = {"autoescape": True, "undefined": jinja2.StrictUndefined}


def environment() -> jinja2.Environment:
    """The report's template environment (autoescaped, every name defined)."""
    return jinja2.Environment(**_OPTIONS)


def digest(source: str) -> str:
    """What a compiled template depends on: its text, the environment's options and jinja2's version."""
    text = f"jinja2 {jinja2.__version__}\n{sorted((k, repr(v)) for k, v in _OPTIONS.items())}\n{source}"
    return hashlib.sha256(text.encode("utf-8")).hexdigest()


def module_text(kind: str, source: str) -> str:
    """The module shipped for template `kind` ("page", "fragment"): jinja2's compiled code, with its DIGEST."""
    code = environment().compile(source, name=kind, raw=True, defer_init=True)
    return (f"# The report's {kind} template (grader.render.html) as jinja2 {jinja2.__version__} compiles it: "
            f"written by\n# `python -m grader.render.html`, never by hand (grader.render.precompiled).\n"
            f'JINJA2 = "{jinja2.__version__}"\nDIGEST = "{digest(source)}"\n{code}\n')


def template(kind: str, source: str) -> jinja2.Template:
    """Template `kind` from its shipped module where that was compiled from `source` here, else compiled now."""
    environment_ = environment()
    try:
        module = importlib.import_module(f"grader.render.compiled.{kind}")
    except Exception:  # noqa: BLE001  missing, or not loadable with this jinja2 or Python: compiled here instead
        module = None
    if module is not None and getattr(module, "DIGEST", None) == digest(source):
        return environment_.template_class.from_module_dict(environment_, vars(module),
                                                            environment_.make_globals(None))
    return environment_.from_string(source)


def write(sources: dict[str, str]) -> list[Path]:
    """Write the module of each template (kind -> its text) into grader/render/compiled."""
    written = []
    for kind, source in sources.items():
        path = FOLDER / f"{kind}.py"
        path.write_text(module_text(kind, source), encoding="utf-8", newline="\n")
        written.append(path)
    return written
