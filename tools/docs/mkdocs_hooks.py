"""MkDocs hooks for the documentation site (mkdocs.yml: `hooks:`).

What the pages need that MkDocs 1.4 does not do:

* `<!-- include: PATH -->` on a line of its own is replaced by the file at
  PATH (relative to the repository root). The manifest format lives beside
  the code that writes it (common/manifest_format.md); the reference page
  includes it instead of keeping a copy that could drift.

* Links to files of the repository outside docs/ (a test, a header, a
  script) are written as ordinary relative links, so they work wherever the
  Markdown is read in the repository. On the site they become the path in
  code (or, when mkdocs.yml sets `repo_url`, a link to the file there). A
  link to a path that does not exist in the repository is left alone, so
  `mkdocs build --strict` fails on it like on any broken link: a renamed test
  breaks the build of the page that names it.

* A list that follows a paragraph line directly starts a list, as on GitHub
  (CommonMark); Python-Markdown would run it into the paragraph. The pages
  were written to read well in the repository too.

* Anchors are checked: a link to page.md#heading whose heading is gone is a
  warning, so --strict fails on it too.

* Pages being written elsewhere (mkdocs.yml `extra: optional_pages:`) may be
  missing: then their nav entry is dropped and links to them show as plain
  text, instead of failing the build. Once such a page exists it is an
  ordinary page; take it off the list.
"""
import logging
import os
import posixpath
import re

log = logging.getLogger("mkdocs.hooks.impostor")

INCLUDE = re.compile(r"^<!--\s*include:\s*(\S+)\s*-->\s*$", re.M)
# [text](target) or ![alt](target), target without spaces; not inside code.
LINK = re.compile(r"(!?)\[((?:[^\[\]`]|`[^`]*`)*)\]\(([^)\s]+)\)")
FENCE = re.compile(r"^(\s*)(```+|~~~+)")


def _repo_root(config):
    # docs/ sits at the repository's root (mkdocs.yml's docs_dir).
    return os.path.dirname(os.path.abspath(config["docs_dir"]))


def _split_code(markdown):
    """Yields (is_code, text) chunks: fenced blocks and inline code spans are code."""
    lines = markdown.split("\n")
    buf, code, fence = [], [], None
    for line in lines:
        if fence is None:
            m = FENCE.match(line)
            if m:
                if buf:
                    yield from _split_inline("\n".join(buf) + "\n")
                    buf = []
                fence = m.group(2)
                code = [line]
            else:
                buf.append(line)
        else:
            code.append(line)
            if line.strip().startswith(fence) and line.strip().strip(fence[0]) == "":
                yield True, "\n".join(code) + "\n"
                code, fence = [], None
    if code:
        yield True, "\n".join(code) + "\n"
    if buf:
        yield from _split_inline("\n".join(buf))


def _split_inline(text):
    # Links whose text is code (`[`x.h`](../x.h)`) must stay whole, so only
    # code spans outside a link's brackets are set aside, and only to keep
    # their contents from being read as links.
    pos = 0
    for m in re.finditer(r"(`+)(?:(?!\1).)+?\1", text, re.S):
        before = text[:m.start()]
        if before.count("[") > before.count("]"):
            continue  # inside a link's text
        if m.start() > pos:
            yield False, text[pos:m.start()]
        yield True, m.group(0)
        pos = m.end()
    if pos < len(text):
        yield False, text[pos:]


def _rewrite_links(markdown, written_in, page_dir, root, docs_dir, repo_url):
    """Rewrites the relative links of `markdown`, written in the repository
    folder `written_in`, for a page in `page_dir` (both relative to root)."""

    def fix(m):
        bang, text, target = m.groups()
        if re.match(r"^[a-z][a-z0-9+.-]*:", target, re.I) or target.startswith(("#", "/")):
            return m.group(0)
        path, _, fragment = target.partition("#")
        repo_path = posixpath.normpath(posixpath.join(written_in, path)) if path else None
        if repo_path is None:
            return m.group(0)
        docs_rel = os.path.relpath(docs_dir, root).replace(os.sep, "/")
        if repo_path == docs_rel or repo_path.startswith(docs_rel + "/"):
            # A page of the site: relative to the page that shows it.
            new = posixpath.relpath(repo_path, page_dir) + ("#" + fragment if fragment else "")
            return f"{bang}[{text}]({new})"
        if not os.path.exists(os.path.join(root, repo_path)):
            return m.group(0)  # broken: --strict reports it
        if repo_url:
            kind = "tree" if os.path.isdir(os.path.join(root, repo_path)) else "blob"
            return f"{bang}[{text}]({repo_url.rstrip('/')}/{kind}/HEAD/{repo_path}{'#' + fragment if fragment else ''})"
        if bang:
            return f"`{repo_path}`"
        plain = text.strip("`").rstrip("/")
        if plain in (repo_path, path.rstrip("/")) or repo_path.endswith("/" + plain):
            return f"`{repo_path}`"
        return f"{text} (`{repo_path}`)"

    out = []
    for is_code, chunk in _split_code(markdown):
        out.append(chunk if is_code else LINK.sub(fix, chunk))
    return "".join(out)


def _lists_after_paragraphs(markdown):
    """Puts a blank line between a paragraph and a top-level list item that
    follows it on the next line (outside code fences)."""
    out, fence, in_list, prev = [], None, False, ""
    for line in markdown.split("\n"):
        m = FENCE.match(line)
        if m and fence is None:
            fence = m.group(2)[0] * 3
        elif fence is not None and line.strip().startswith(fence):
            fence = None
            out.append(line)
            prev = line
            continue
        if fence is None:
            if re.match(r"^([-*+]|\d+\.)\s+\S", line):
                if prev.strip() and not in_list and not prev.lstrip().startswith(("|", "#", "<")):
                    out.append("")
                in_list = True
            elif line.strip() and not line[0].isspace() and not prev.strip():
                in_list = False
        out.append(line)
        prev = line
    return "\n".join(out)


def _missing_optional(config):
    docs_dir = os.path.abspath(config["docs_dir"])
    optional = (config.get("extra") or {}).get("optional_pages") or []
    return {p for p in optional if not os.path.isfile(os.path.join(docs_dir, p))}


def _drop_from_nav(items, missing):
    kept = []
    for item in items:
        if isinstance(item, dict):
            (title, value), = item.items()
            if isinstance(value, list):
                value = _drop_from_nav(value, missing)
                if not value:
                    continue
            elif value in missing:
                continue
            kept.append({title: value})
        elif item not in missing:
            kept.append(item)
    return kept


def on_config(config):
    missing = _missing_optional(config)
    if missing and config.get("nav"):
        for page in sorted(missing):
            log.info(f"Optional page '{page}' is not written yet: left out of the nav, links to it shown as text")
        config["nav"] = _drop_from_nav(config["nav"], missing)
    return config


def on_page_markdown(markdown, page, config, files):
    root = _repo_root(config)
    docs_dir = os.path.abspath(config["docs_dir"])
    docs_rel = os.path.relpath(docs_dir, root).replace(os.sep, "/")
    page_dir = posixpath.join(docs_rel, posixpath.dirname(page.file.src_uri))
    repo_url = config.get("repo_url")

    def include(m):
        rel = m.group(1)
        full = os.path.join(root, rel)
        if not os.path.isfile(full):
            log.warning(f"Documentation file '{page.file.src_uri}' includes '{rel}', which does not exist")
            return m.group(0)
        with open(full, encoding="utf-8") as f:
            text = f.read()
        # Its links are relative to where it lives.
        return _rewrite_links(text, posixpath.dirname(rel), page_dir, root, docs_dir, repo_url)

    markdown = INCLUDE.sub(include, markdown)
    markdown = _rewrite_links(markdown, page_dir, page_dir, root, docs_dir, repo_url)
    markdown = _lists_after_paragraphs(markdown)
    missing = _missing_optional(config)
    if missing:
        def unlink(m):
            bang, text, target = m.groups()
            path = target.partition("#")[0]
            resolved = posixpath.normpath(posixpath.join(posixpath.dirname(page.file.src_uri), path))
            return f"{text} (not written yet)" if path and resolved in missing else m.group(0)
        markdown = "".join(chunk if is_code else LINK.sub(unlink, chunk) for is_code, chunk in _split_code(markdown))
    return markdown


# Anchors. MkDocs 1.4 checks that a linked page exists, not that the heading
# a link names (page.md#heading) is on it; a renamed heading would leave a
# link that silently lands at the top. Every page's ids and every internal
# link with a fragment are collected as pages render, and checked once all
# have (a warning, so --strict fails).
_ids = {}
_links = []


def on_pre_build(config):
    _ids.clear()
    _links.clear()


def on_page_content(html, page, config, files):
    url = "/" + page.url
    _ids[url] = set(re.findall(r'\bid="([^"]+)"', html))
    for href in re.findall(r'\bhref="([^"]*#[^"]+)"', html):
        if re.match(r"^[a-z][a-z0-9+.-]*:", href, re.I):
            continue
        _links.append((page.file.src_uri, url, href))
    return html


def on_post_build(config):
    for src, url, href in _links:
        path, _, fragment = href.partition("#")
        target = posixpath.normpath(posixpath.join(posixpath.dirname(url) if not url.endswith("/") else url, path))
        if path == "":
            target = url
        if not target.endswith("/") and not target.endswith(".html"):
            target += "/"
        if target == "//":
            target = "/"
        ids = _ids.get(target)
        if ids is None:
            continue  # not a page of the site (MkDocs reports missing pages itself)
        if fragment not in ids:
            log.warning(f"Documentation file '{src}' links to '{href}': no heading or anchor "
                        f"'#{fragment}' on that page")
