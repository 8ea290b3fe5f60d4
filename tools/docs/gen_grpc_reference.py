#!/usr/bin/env python3
"""Renders docs/reference/grpc-api.md from proto/impostor/v1/*.proto.

The page is the protos' own comments, laid out: every service with its rpcs,
every message with its fields, every enum with its values, each with the
comment written above it (or after it, on the same line). Nothing is written
by hand, so the page cannot drift from the API; change the comments in the
.proto files and run this again (or `bash tools/docs/gen_reference.sh`).

    gen_grpc_reference.py [--proto-dir proto/impostor/v1] [--out docs/reference/grpc-api.md]

Standard library only. It reads the subset of proto3 this repository uses:
services, rpcs (with `stream`), messages and enums (nested too), fields with
`optional`/`repeated`/`map<K, V>`, `oneof`, `reserved`, options and imports.
"""
import argparse
import os
import re
import sys

SERVICE_ORDER = ["bake_service.proto", "asset_service.proto", "worker_service.proto", "admin_service.proto"]
SCALARS = {"double", "float", "int32", "int64", "uint32", "uint64", "sint32", "sint64", "fixed32", "fixed64",
           "sfixed32", "sfixed64", "bool", "string", "bytes"}


class Node:
    def __init__(self, kind, name, doc, parent=None):
        self.kind = kind  # service, rpc, message, enum, field, value, oneof
        self.name = name
        self.doc = doc
        self.parent = parent
        self.children = []
        self.detail = {}

    def full_name(self):
        parts = []
        node = self
        while node is not None and node.kind in ("message", "enum"):
            parts.append(node.name)
            node = node.parent
        return ".".join(reversed(parts))


def strip_comment(line):
    """Splits a line into (code, comment) at a `//` outside string literals."""
    in_string = None
    for i, ch in enumerate(line):
        if in_string:
            if ch == in_string:
                in_string = None
        elif ch in "\"'":
            in_string = ch
        elif line.startswith("//", i):
            return line[:i], line[i:]
    return line, None


def comment_text(comment):
    text = comment[2:]
    return text[1:] if text.startswith(" ") else text


def parse_file(path):
    with open(path, encoding="utf-8") as f:
        lines = f.read().split("\n")
    root = Node("file", os.path.basename(path), [])
    stack = [root]
    pending = []          # leading comment lines for the next declaration
    seen_code = False     # before the first statement: the file's own comment
    last = None           # last declaration, for trailing comments
    last_col = None       # column of its trailing comment, for continuations
    for raw in lines:
        code, comment = strip_comment(raw)
        code = code.strip()
        if not code:
            if comment is not None:
                col = raw.index("//")
                if last is not None and last_col is not None and col == last_col and not pending:
                    last.doc.append(comment_text(comment.strip()))  # a trailing comment's next line
                else:
                    pending.append(comment_text(comment.strip()))
                    last_col = None
            else:
                # A blank line: a comment block above it belongs to nothing
                # below, except the file's opening comment.
                if pending and not seen_code and not root.doc:
                    root.doc = pending
                pending = []
                last_col = None
            continue
        seen_code = True
        node = None
        parent = stack[-1]
        m = re.match(r"(service|message|enum|oneof)\s+(\w+)\s*\{\s*(\})?", code)
        if m:
            kind, name, closed = m.groups()
            node = Node(kind, name, pending, parent)
            parent.children.append(node)
            if not closed:
                stack.append(node)
        elif code.startswith("}"):
            stack.pop()
        elif code.startswith(("syntax", "package", "import", "option", "reserved", "extensions")):
            if code.startswith("package"):
                root.detail["package"] = code.split()[1].rstrip(";")
        else:
            m = re.match(r"rpc\s+(\w+)\s*\(\s*(stream\s+)?([\w.]+)\s*\)\s*returns\s*\(\s*(stream\s+)?([\w.]+)\s*\)", code)
            if m:
                node = Node("rpc", m.group(1), pending, parent)
                node.detail = {"request": m.group(3), "request_stream": bool(m.group(2)),
                               "response": m.group(5), "response_stream": bool(m.group(4))}
                parent.children.append(node)
            elif parent.kind == "enum":
                m = re.match(r"(\w+)\s*=\s*(-?\d+)", code)
                if m:
                    node = Node("value", m.group(1), pending, parent)
                    node.detail = {"number": m.group(2)}
                    parent.children.append(node)
            else:
                m = re.match(r"(optional\s+|repeated\s+)?(map\s*<\s*[\w.]+\s*,\s*[\w.]+\s*>|[\w.]+)\s+(\w+)\s*=\s*(\d+)", code)
                if m:
                    label = (m.group(1) or "").strip()
                    node = Node("field", m.group(3), pending, parent)
                    node.detail = {"label": label, "type": re.sub(r"\s+", "", m.group(2)).replace(",", ", "),
                                   "number": m.group(4),
                                   "oneof": parent.name if parent.kind == "oneof" else None}
                    parent.children.append(node)
        pending = []
        last = node
        last_col = None
        if node is not None and comment is not None:
            node.doc = node.doc + [comment_text(comment.strip())]
            last_col = raw.index("//")
    return root


def slug(text):
    # Python-Markdown's toc slugify: lower case, drop what is not a word
    # character, space or hyphen, spaces to hyphens.
    text = re.sub(r"[^\w\s-]", "", text).strip().lower()
    return re.sub(r"[-\s]+", "-", text)


def escape_md(text):
    """Escapes Markdown and HTML outside `code spans`."""
    parts = re.split(r"(`[^`]*`)", text)
    out = []
    for part in parts:
        if part.startswith("`") and part.endswith("`") and len(part) > 1:
            out.append(part)
        else:
            part = part.replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;")
            part = re.sub(r"([*\\])", r"\\\1", part)
            # Underscores inside words (request_id) are no emphasis; at a
            # word's edge they could be.
            part = re.sub(r"(?<!\w)_|_(?!\w)", r"\\_", part)
            out.append(part)
    return "".join(out)


def render_doc(doc_lines, indent=""):
    """A comment block as Markdown: plain lines join into paragraphs; lines
    indented by two or more spaces (tables, examples) stay as they are."""
    out = []
    para = []
    block = []

    def flush_para():
        if para:
            out.append(indent + escape_md(" ".join(s.strip() for s in para)))
            out.append("")
            para.clear()

    def flush_block():
        if block:
            out.append(indent + "```text")
            out.extend(indent + b for b in block)
            out.append(indent + "```")
            out.append("")
            block.clear()

    for line in doc_lines:
        if not line.strip():
            flush_para()
            flush_block()
        elif line.startswith("  "):
            flush_para()
            block.append(line.rstrip())
        else:
            flush_block()
            para.append(line)
    flush_para()
    flush_block()
    return out


class Index:
    """Where each message and enum is documented, for links."""

    def __init__(self, files):
        self.names = {}
        for f in files:
            for node in walk(f):
                if node.kind in ("message", "enum"):
                    self.names[node.full_name()] = slug(node.full_name())

    def link(self, type_name, scope):
        if type_name in SCALARS:
            return f"`{type_name}`"
        m = re.match(r"map<([\w.]+), ([\w.]+)>", type_name)
        if m:
            return f"map&lt;{self.link(m.group(1), scope)}, {self.link(m.group(2), scope)}&gt;"
        name = type_name
        if name.startswith("impostor.v1."):
            name = name[len("impostor.v1."):]
        # Resolve as protoc does: innermost scope first.
        candidates = []
        s = scope
        while s:
            candidates.append(s + "." + name)
            s = s.rpartition(".")[0]
        candidates.append(name)
        for c in candidates:
            if c in self.names:
                return f"[`{type_name}`](#{self.names[c]})"
        return f"`{type_name}`"


def walk(node):
    for child in node.children:
        yield child
        yield from walk(child)


def render_message(node, index, level, out):
    full = node.full_name()
    out.append(f"{'#' * level} {full}")
    out.append("")
    out.extend(render_doc(node.doc))
    if node.kind == "enum":
        values = [c for c in node.children if c.kind == "value"]
        if values:
            out.append("| Value | Number | Meaning |")
            out.append("|---|---|---|")
            for v in values:
                out.append(f"| `{v.name}` | {v.detail['number']} | {escape_md(' '.join(s.strip() for s in v.doc)).replace('|', '&#124;')} |")
            out.append("")
        return
    fields = []
    for c in node.children:
        if c.kind == "field":
            fields.append(c)
        elif c.kind == "oneof":
            for f in c.children:
                if f.kind == "field":
                    f.detail["oneof_doc"] = c.doc
                    fields.append(f)
    if fields:
        for f in fields:
            label = f.detail["label"]
            type_link = index.link(f.detail["type"], full)
            prefix = f"{label} " if label else ""
            oneof = f" (one of `{f.detail['oneof']}`)" if f.detail.get("oneof") else ""
            out.append(f"- **`{f.name}`** = {f.detail['number']}: {prefix}{type_link}{oneof}")
            body = render_doc(f.doc, indent="    ")
            if body:
                out.append("")
                out.extend(body)
        out.append("")
    else:
        out.append("*No fields.*")
        out.append("")
    for c in node.children:
        if c.kind in ("message", "enum"):
            render_message(c, index, level, out)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    root = os.path.normpath(os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", ".."))
    parser.add_argument("--proto-dir", default=os.path.join(root, "proto", "impostor", "v1"))
    parser.add_argument("--out", default=os.path.join(root, "docs", "reference", "grpc-api.md"))
    args = parser.parse_args()

    names = sorted(n for n in os.listdir(args.proto_dir) if n.endswith(".proto"))
    ordered = [n for n in SERVICE_ORDER if n in names] + [n for n in names if n not in SERVICE_ORDER]
    files = [parse_file(os.path.join(args.proto_dir, n)) for n in ordered]
    index = Index(files)
    package = next((f.detail["package"] for f in files if "package" in f.detail), "impostor.v1")
    rel_dir = os.path.relpath(args.proto_dir, root) if args.proto_dir.startswith(root) else args.proto_dir

    out = [
        f"# gRPC API (`{package}`)",
        "",
        "<!-- Generated by tools/docs/gen_grpc_reference.py from the .proto files' comments;",
        "     do not edit: edit the comments and run `bash tools/docs/gen_reference.sh`. -->",
        "",
        f"Generated from the comments in `{rel_dir}/*.proto`; the .proto files are the",
        "source of truth (how to regenerate: [the reference's index](index.md)).",
        "",
    ]
    services = [(f, s) for f in files for s in f.children if s.kind == "service"]
    out.append("## Services")
    out.append("")
    for f, s in services:
        rpcs = [r for r in s.children if r.kind == "rpc"]
        out.append(f"- [{s.name}](#{slug(s.name)}) (`{f.name}`): " + ", ".join(r.name for r in rpcs))
    out.append("")
    for f, s in services:
        out.append(f"### {s.name}")
        out.append("")
        out.append(f"`{f.name}`")
        out.append("")
        out.extend(render_doc(s.doc))
        for r in s.children:
            if r.kind != "rpc":
                continue
            d = r.detail
            req = ("stream " if d["request_stream"] else "") + index.link(d["request"], "")
            resp = ("stream " if d["response_stream"] else "") + index.link(d["response"], "")
            out.append(f"#### {s.name}.{r.name}")
            out.append("")
            out.append(f"`rpc {r.name}` ({req}) returns ({resp})")
            out.append("")
            out.extend(render_doc(r.doc))
    for f in files:
        decls = [c for c in f.children if c.kind in ("message", "enum")]
        if not decls:
            continue
        out.append(f"## Messages of `{f.name}`")
        out.append("")
        out.extend(render_doc(f.doc))
        for c in decls:
            render_message(c, index, 3, out)
    while out and not out[-1]:
        out.pop()
    text = "\n".join(out) + "\n"
    os.makedirs(os.path.dirname(os.path.abspath(args.out)), exist_ok=True)
    with open(args.out, "w", encoding="utf-8") as fh:
        fh.write(text)
    print(f"wrote {args.out}", file=sys.stderr)


if __name__ == "__main__":
    main()
