"""MkDocs hook: the pages generated at build time, never hand-copied.

* ``reference/api/<module>.md``: one page per module of ``pneucore`` (found on disk, so a new
  module gets its page without an edit here), each a mkdocstrings ``::: module`` block: the
  API reference is the docstrings, units included. ``reference/api/index.md`` lists them
  with each module's first docstring line, and the nav's "Python API" section is filled
  with them, grouped by subpackage.
* ``reference/rest.md``: every endpoint of the service with its request and response
  schemas, and every schema's fields with their descriptions (where the units are), from the
  OpenAPI document of ``app.main.app``; ``openapi.json`` beside it is that document.
"""
from __future__ import annotations

import ast
import json
import re
import sys
from pathlib import Path

from markdown import Extension
from markdown.preprocessors import Preprocessor
from mkdocs.plugins import event_priority
from mkdocs.structure.files import File

ROOT = Path(__file__).resolve().parents[2]
PACKAGE = "pneucore"
#: the nav section the module pages go into (a title in mkdocs.yml's nav)
API_SECTION = "Python API"
API_DIR = "reference/api"


# ---------------------------------------------------------------------------- docstrings as Markdown

#: ``[0, t_end] [s]``, ``[-1, 1] [-]``: a range and a unit, which Markdown reads as a reference link
_RANGE_UNIT = re.compile(r"(?<!\\)\](\s+)\[")


def plain_brackets(text: str) -> str:
    """Escape the ``] [`` of a range followed by a unit (outside code spans)."""
    parts = text.split("`")
    return "`".join(_RANGE_UNIT.sub(r"\\]\1[", p) if i % 2 == 0 else p for i, p in enumerate(parts))


#: a Sphinx role of the docstrings: :class:`~pneucore.description.model.Model`, :func:`simulate`
_ROLE = re.compile(r":(?:py:)?(?:class|func|meth|mod|data|attr|obj|exc|const):`(~?)([^`<>]+)`")


def _role(m) -> str:
    """A role as a link where mkdocstrings documents its target (autorefs' optional reference:
    plain code where it does not, e.g. a name relative to its module)."""
    target = m.group(2).strip().removesuffix("()")
    title = target.rsplit(".", 1)[-1] if m.group(1) else target
    return f'<autoref identifier="{target}" optional><code>{title}</code></autoref>'


def sphinx_roles(text: str) -> str:
    return _ROLE.sub(_role, text)


class _Docstrings(Preprocessor):
    """Docstrings are numpydoc, read as Markdown: a doctest outside an ``Examples`` section
    (``>>> f(x)[:3]``) becomes a code block, and a range followed by its unit stays text."""

    def run(self, lines):
        return plain_brackets_outside_code(self._fence_doctests(lines))

    @staticmethod
    def _fence_doctests(lines):
        out, fence, block = [], False, False
        for line in lines:
            stripped = line.lstrip()
            if stripped.startswith(("```", "~~~")):
                if block:
                    out.append("```")
                    block = False
                fence = not fence
                out.append(line)
                continue
            if fence:
                out.append(line)
                continue
            if block and not stripped:
                out += ["```", line]
                block = False
                continue
            if not block and stripped.startswith(">>>"):
                if out and out[-1].strip():
                    out.append("")
                out.append("```python")
                block = True
            out.append(line)
        if block:
            out.append("```")
        return out


def plain_brackets_outside_code(lines):
    """:func:`plain_brackets` on every run of lines outside code fences (a range and its
    unit may be on two lines)."""
    out, run, fence = [], [], False
    for line in lines + ["```"]:
        if line.lstrip().startswith(("```", "~~~")):
            if not fence and run:
                out += sphinx_roles(plain_brackets("\n".join(run))).split("\n")
            run = []
            fence = not fence
            out.append(line)
        elif fence:
            out.append(line)
        else:
            run.append(line)
    return out[:-1]


class DocstringExtension(Extension):
    def extendMarkdown(self, md):
        # before fenced_code (25), which turns the blocks made here into code
        md.preprocessors.register(_Docstrings(md), "pneucore_docstrings", 27)


# ---------------------------------------------------------------------------- modules

def modules(package: str = PACKAGE) -> list[str]:
    """Every module of the package, dotted, in path order (packages by their ``__init__``)."""
    base = ROOT / package
    names = []
    for path in sorted(base.rglob("*.py")):
        if "__pycache__" in path.parts:
            continue
        rel = path.relative_to(ROOT).with_suffix("")
        parts = list(rel.parts)
        if parts[-1] == "__init__":
            parts = parts[:-1]
        names.append(".".join(parts))
    return sorted(set(names))


def _is_package(name: str) -> bool:
    return (ROOT / Path(*name.split(".")) / "__init__.py").exists()


def _source(name: str) -> Path:
    p = ROOT / Path(*name.split("."))
    return p / "__init__.py" if p.is_dir() else p.with_suffix(".py")


def summary(name: str) -> str:
    """The first line of a module's docstring (read without importing it)."""
    try:
        doc = ast.get_docstring(ast.parse(_source(name).read_text(encoding="utf-8")))
    except (OSError, SyntaxError):
        doc = None
    if not doc:
        return ""
    first = doc.strip().split("\n\n")[0]
    return " ".join(first.split())


def page_path(name: str) -> str:
    return f"{API_DIR}/{name}.md"


def _group(name: str) -> str:
    """The subpackage a module's page is listed under in the nav."""
    parts = name.split(".")
    if len(parts) == 1:
        return PACKAGE
    if _is_package(name) and len(parts) == 2:
        return name
    return ".".join(parts[:2]) if _is_package(".".join(parts[:2])) else PACKAGE


def _api_nav() -> list:
    groups: dict[str, list] = {}
    for name in modules():
        groups.setdefault(_group(name), []).append({name: page_path(name)})
    return [{"Overview": f"{API_DIR}/index.md"}] + [{g: items} for g, items in groups.items()]


def _module_page(name: str) -> str:
    return (f"# `{name}`\n\n"
            f"Source: `{_source(name).relative_to(ROOT).as_posix()}`\n\n"
            f"::: {name}\n")


def _api_index() -> str:
    lines = ["# Python API", "",
             "One page per module of `pneucore`, generated from the docstrings at build time "
             "(units in brackets, as the code states them). `import pneucore` gives the public "
             "API: `simulate`, `Model`, `Scenario`, the presets and the registries; the "
             "[package layout](../layout.md) says what each subpackage holds.", "",
             "| module | summary |", "|---|---|"]
    for name in modules():
        lines.append(f"| [`{name}`]({name}.md) | {_cell(summary(name))} |")
    return "\n".join(lines) + "\n"


# ---------------------------------------------------------------------------- REST

def _cell(text) -> str:
    text = " ".join(str(text).split())
    return text.replace("|", "\\|").replace("<", "&lt;").replace(">", "&gt;")


def _anchor(name: str) -> str:
    return "schema-" + "".join(c if c.isalnum() else "-" for c in name).lower()


def _type(schema: dict) -> str:
    """A schema's type in a few words, with links to the named schemas it uses."""
    if not isinstance(schema, dict):
        return ""
    if "$ref" in schema:
        name = schema["$ref"].rsplit("/", 1)[-1]
        return f"[{name}](#{_anchor(name)})"
    for key in ("anyOf", "oneOf", "allOf"):
        if key in schema:
            parts = [_type(s) for s in schema[key]]
            return " or ".join(p for p in parts if p) or "any"
    t = schema.get("type")
    if t == "array":
        return f"array of {_type(schema.get('items', {})) or 'any'}"
    if t == "object" and isinstance(schema.get("additionalProperties"), dict):
        return f"object of {_type(schema['additionalProperties']) or 'any'}"
    if "enum" in schema:
        return " \\| ".join(f"`{json.dumps(v)}`" for v in schema["enum"])
    if "const" in schema:
        return f"`{json.dumps(schema['const'])}`"
    if isinstance(t, list):
        return " or ".join(t)
    return t or "any"


def _content_types(body: dict) -> list[tuple[str, dict]]:
    return list((body or {}).get("content", {}).items())


def openapi_document() -> dict:
    """The service's OpenAPI document, as ``GET /openapi.json`` answers it."""
    if str(ROOT) not in sys.path:
        sys.path.insert(0, str(ROOT))
    from app.main import app
    return app.openapi()


def rest_page(spec: dict) -> str:
    info = spec.get("info", {})
    out = ["# REST reference", "",
           f"Generated at build time from the service's OpenAPI document ({_cell(info.get('title', ''))} "
           f"{_cell(info.get('version', ''))}; the same document the running service answers at "
           "`/openapi.json` and draws at `/docs` and `/redoc`; [download it](openapi.json)). "
           "Units are in each field's description; pressures are absolute in Pa unless a field "
           "says otherwise. The [REST API overview](rest-api.md) groups the endpoints by task "
           "and gives the error codes.", ""]
    paths = spec.get("paths", {})
    by_tag: dict[str, list] = {}
    for path, ops in paths.items():
        for method, op in ops.items():
            if method not in ("get", "post", "put", "patch", "delete"):
                continue
            tag = (op.get("tags") or ["other"])[0]
            by_tag.setdefault(tag, []).append((path, method, op))
    # the error answers most operations share, listed once
    counts: dict = {}
    n_ops = sum(len(v) for v in by_tag.values())
    for ops in by_tag.values():
        for _, _, op in ops:
            for code, resp in (op.get("responses") or {}).items():
                if not str(code).startswith("2"):
                    counts[_response_key(code, resp)] = (counts.get(_response_key(code, resp), (0, resp))[0] + 1, resp)
    common = {k: resp for k, (n, resp) in counts.items() if n > n_ops / 2}
    out += ["## Endpoints", "", "| group | endpoint | does |", "|---|---|---|"]
    for tag in sorted(by_tag):
        for path, method, op in by_tag[tag]:
            out.append(f"| {tag} | [`{method.upper()} {path}`](#{_op_anchor(method, path)}) | "
                       f"{_cell(op.get('summary', ''))} |")
    out.append("")
    for tag in sorted(by_tag):
        out += [f"## {tag}", ""]
        for path, method, op in by_tag[tag]:
            out += [f"### `{method.upper()} {path}` {{#{_op_anchor(method, path)}}}", ""]
            if op.get("summary"):
                out += [f"**{_cell(op['summary'])}**", ""]
            if op.get("description"):
                out += [op["description"].strip(), ""]
            params = op.get("parameters") or []
            if params:
                out += ["| parameter | in | type | required | description |", "|---|---|---|---|---|"]
                for p in params:
                    out.append(f"| `{p.get('name')}` | {p.get('in')} | {_type(p.get('schema', {}))} | "
                               f"{'yes' if p.get('required') else 'no'} | "
                               f"{_cell(p.get('description') or p.get('schema', {}).get('description', ''))} |")
                out.append("")
            body = op.get("requestBody")
            if body:
                out += ["Request body:", ""]
                for ctype, c in _content_types(body):
                    out.append(f"- `{ctype}`: {_type(c.get('schema', {}))}")
                out.append("")
            out += ["| status | answer |", "|---|---|"]
            shared = []
            for code, resp in (op.get("responses") or {}).items():
                if _response_key(code, resp) in common:
                    shared.append(code)
                else:
                    out.append(_response_row(code, resp))
            out.append("")
            if shared:
                out += [f"Also the [common errors](#common-errors): {', '.join(sorted(shared))}.", ""]
    out += ["## Common errors {#common-errors}", "",
            "The error answers most operations share (each operation names those it may give).", "",
            "| status | answer |", "|---|---|"]
    out += [_response_row(k[0], resp) for k, resp in sorted(common.items())]
    out.append("")
    out += ["## Schemas", ""]
    for name, schema in sorted(spec.get("components", {}).get("schemas", {}).items()):
        out += [f"### {name} {{#{_anchor(name)}}}", ""]
        if schema.get("description"):
            out += [_cell(schema["description"]), ""]
        props = schema.get("properties") or {}
        required = set(schema.get("required") or [])
        if props:
            out += ["| field | type | required | default | description |", "|---|---|---|---|---|"]
            for field, fs in props.items():
                default = f"`{_cell(json.dumps(fs['default']))}`" if "default" in fs else ""
                out.append(f"| `{field}` | {_type(fs)} | {'yes' if field in required else 'no'} | "
                           f"{default} | {_cell(fs.get('description', fs.get('title', '')))} |")
            out.append("")
        elif "enum" in schema or "type" in schema:
            out += [f"Type: {_type(schema)}", ""]
    return "\n".join(out) + "\n"


def _content(ctype: str, content: dict) -> str:
    """A response's media type, its schema and, where the schema says it, what it holds."""
    schema = content.get("schema", {})
    text = f"`{ctype}` {_type(schema)}"
    if "$ref" not in schema and schema.get("description"):
        text += f" ({_cell(schema['description'])})"
    return text


def _response_key(code, resp: dict) -> tuple:
    return (str(code), json.dumps(resp, sort_keys=True))


def _response_row(code, resp: dict) -> str:
    kinds = "; ".join(_content(ct, c) for ct, c in _content_types(resp))
    return f"| {code} | {_cell(resp.get('description', ''))}{': ' + kinds if kinds else ''} |"


def _op_anchor(method: str, path: str) -> str:
    return "op-" + method + "".join(c if c.isalnum() else "-" for c in path).lower()


# ---------------------------------------------------------------------------- hooks

@event_priority(100)   # before mkdocstrings reads the Markdown extensions
def on_config(config, **kwargs):
    config.markdown_extensions.append(DocstringExtension())
    for entry in config.get("nav") or []:
        _fill(entry)
    return config


def _fill(entry):
    """Put the module pages into the nav section titled ``API_SECTION``, wherever it is."""
    if not isinstance(entry, dict):
        return
    for title, value in entry.items():
        if title == API_SECTION:
            entry[title] = _api_nav()
        elif isinstance(value, list):
            for sub in value:
                _fill(sub)


def on_files(files, config, **kwargs):
    for name in modules():
        files.append(File.generated(config, page_path(name), content=_module_page(name)))
    files.append(File.generated(config, f"{API_DIR}/index.md", content=_api_index()))
    spec = openapi_document()
    files.append(File.generated(config, "reference/rest.md", content=rest_page(spec)))
    files.append(File.generated(config, "reference/openapi.json",
                                content=json.dumps(spec, indent=1, ensure_ascii=False)))
    return files
