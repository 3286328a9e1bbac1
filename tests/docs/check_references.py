#!/usr/bin/env python3
"""ctest `docs.references`: every documentation reference in the sources resolves.

    python3 tests/docs/check_references.py <source root>

Scans the sources, scripts, scenes, CMake files and Markdown pages of the repository (not build
trees) for
  * plain references  docs/<page>.md  and  docs/<page>.md#<anchor>  (code comments, scripts, docs);
  * relative Markdown links  [text](<page>.md#<anchor>)  and  [text](#<anchor>)  in *.md files,
and fails if the page does not exist or has no such anchor. Anchors are explicit HTML anchors
(<a id="..."> or <a name="...">) and the GitHub slugs of the page's headings. It also fails if any
file cites the design notes that are not part of the repository (the former MATH.md, DESIGN.md,
STYLE.md or a ../shared path): the repository must stand on its own.
Prints one line per problem (file:line: what) and exits 1 if there is any, else prints a summary.
"""
import pathlib
import re
import sys

SUFFIXES = {".hpp", ".cpp", ".h", ".md", ".py", ".sh", ".toml", ".cmake", ".in", ".txt"}
SKIP_DIRS = {".git", "build", "out", "__pycache__"}
PLAIN = re.compile(r"(?<![\w/.])docs/([\w./-]+?\.md)(?:#([\w-]+))?")
LINK = re.compile(r"\]\((?!https?:)([^)\s#]*?\.md)?#([\w-]+)\)")
# Built from parts so that this file does not match itself.
FORBIDDEN = re.compile(r"\b(?:" + "|".join(["MA" + "TH", "DE" + "SIGN", "ST" + "YLE"]) + r")\.md\b|\.\./" + "shared")
ANCHOR = re.compile(r"<a\s+(?:id|name)=\"([^\"]+)\"")
HEADING = re.compile(r"^(#{1,6})\s+(.*?)\s*#*\s*$")


def slug(heading):
    """GitHub's heading id: lower case, markup and punctuation dropped, spaces to hyphens."""
    text = re.sub(r"<[^>]+>", "", heading)
    text = re.sub(r"\[([^\]]*)\]\([^)]*\)", r"\1", text)  # links: keep the text
    text = text.lower().replace("`", "")
    text = re.sub(r"[^\w\- ]", "", text)
    return text.replace(" ", "-")


def anchors_of(page, cache={}):
    if page not in cache:
        ids = set()
        counts = {}
        in_code = False
        for line in page.read_text(encoding="utf-8").splitlines():
            if line.lstrip().startswith("```"):
                in_code = not in_code
                continue
            if in_code:
                continue
            ids.update(ANCHOR.findall(line))
            m = HEADING.match(line)
            if m:
                s = slug(m.group(2))
                n = counts.get(s, 0)
                counts[s] = n + 1
                ids.add(s if n == 0 else f"{s}-{n}")
        cache[page] = ids
    return cache[page]


def sources(root):
    for path in sorted(root.rglob("*")):
        rel = path.relative_to(root)
        if any(part in SKIP_DIRS or part.startswith("build") for part in rel.parts[:-1]):
            continue
        if path.is_file() and (path.suffix in SUFFIXES or path.name == "CMakeLists.txt"):
            yield path, rel


def main():
    if len(sys.argv) != 2:
        print("usage: check_references.py <source root>", file=sys.stderr)
        return 2
    root = pathlib.Path(sys.argv[1]).resolve()
    if not (root / "docs").is_dir():
        print(f"check_references.py: {root} has no docs/ folder", file=sys.stderr)
        return 2
    this = pathlib.Path(__file__).resolve()
    problems, checked = [], 0

    def check(rel, lineno, page, anchor, shown):
        nonlocal checked
        checked += 1
        if not page.is_file():
            problems.append(f"{rel}:{lineno}: {shown}: no such page")
        elif anchor and anchor not in anchors_of(page):
            problems.append(f"{rel}:{lineno}: {shown}: no heading or anchor '#{anchor}' in {page.relative_to(root)}")

    for path, rel in sources(root):
        if path.resolve() == this:
            continue
        try:
            text = path.read_text(encoding="utf-8")
        except UnicodeDecodeError:
            continue
        markdown = path.suffix == ".md"
        for lineno, line in enumerate(text.splitlines(), 1):
            if FORBIDDEN.search(line):
                problems.append(f"{rel}:{lineno}: cites a design note outside the repository: {line.strip()}")
            for m in PLAIN.finditer(line):
                check(rel, lineno, root / "docs" / m.group(1), m.group(2), m.group(0))
            if markdown:
                for m in LINK.finditer(line):
                    page = (path.parent / m.group(1)) if m.group(1) else path
                    check(rel, lineno, page.resolve(), m.group(2), m.group(0))
    for p in problems:
        print(p)
    if problems:
        print(f"{len(problems)} broken or forbidden reference(s) ({checked} checked)")
        return 1
    print(f"docs references: {checked} checked, all resolve")
    return 0


if __name__ == "__main__":
    sys.exit(main())
