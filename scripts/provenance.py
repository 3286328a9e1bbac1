#!/usr/bin/env python3
"""Where each table and figure of the results pages came from (docs/examples.md, docs/dynamics.md).

Every Markdown table and every image in those pages has, in the same section (the lines between the
nearest heading above it and the next heading of any level), a source line of one of these forms:

  Source: `COMMAND` [, `COMMAND` ...] at commit HASH (DATE).
        written by the generator itself (`stamp` below): HASH is the commit checked out when the
        command ran, so a later change of the scripts or the library shows as commits after HASH;
  Source: `COMMAND` [...]; committed in HASH (DATE).
        for outputs whose generating commit was not recorded: HASH is the commit that last changed
        them (git history), an upper bound of the code they came from;
  Source: hand-written (REASON).
        tables only (definitions, comparisons quoting the generated tables); never for an image.

  scripts/provenance.py stamp 'COMMAND' ['COMMAND' ...]   # prints the first form for the checkout
  scripts/provenance.py check [ROOT] [--stale]           # the ctest docs.provenance
  scripts/provenance.py selftest                         # the check on small broken pages

`check` fails (exit 1, one line per problem) if a table or image has no source line in its
section, an image file is missing, a source line names no command or a repository path in a command
(scripts/..., bench/..., data/...) that does not exist, a HASH is not a commit in the history of HEAD
(checked only in a full, non-shallow git clone), or a stamp says the tree had uncommitted changes.
With --stale it also lists, per source line, the commits after HASH that changed the scripts its
commands name: a figure older than its generator is visible there.

`stamp` writes "at commit HASH with uncommitted changes" when files outside docs/ and out/ differ
from HASH; `check` rejects that form, so a committed page always names code that exists.
"""
import datetime
import pathlib
import re
import subprocess
import sys

PAGES = ("docs/examples.md", "docs/dynamics.md")
HEADING = re.compile(r"^#{1,6}\s")
IMAGE = re.compile(r"!\[[^\]]*\]\(([^)\s]+)\)")
SOURCE = re.compile(r"^\s*(?:<sub>)?Source:\s*(.*)$")
HASH = re.compile(r"\b(?:at commit|committed in)\s+([0-9a-f]{7,40})\b")
COMMAND = re.compile(r"`([^`]+)`")
REPO_PATH = re.compile(r"(?<![\w./-])((?:scripts|bench|data|tests)/[\w./-]+)")


def git(root, *args):
    try:
        r = subprocess.run(["git", "-C", str(root), *args], capture_output=True, text=True, timeout=60)
    except (OSError, subprocess.TimeoutExpired):
        return None
    return r.stdout.strip() if r.returncode == 0 else None


def stamp(commands, root):
    """The source line for outputs the given commands produce now, in the checkout at root."""
    head = git(root, "rev-parse", "--short=10", "HEAD")
    cmds = ", ".join(f"`{c}`" for c in commands)
    if head is None:
        return f"Source: {cmds} outside a git checkout ({datetime.date.today().isoformat()})."
    dirty = git(root, "status", "--porcelain", "--", ".", ":!docs", ":!out")
    date = git(root, "log", "-1", "--format=%cs", "HEAD")
    extra = " with uncommitted changes" if dirty else ""
    return f"Source: {cmds} at commit {head}{extra} ({date})."


def sections(lines):
    """(first, last) line index ranges of the heading sections (the lines before the first heading
    form a section too)."""
    starts = [0] + [i for i, l in enumerate(lines) if HEADING.match(l) and i > 0]
    return [(a, b - 1) for a, b in zip(starts, starts[1:] + [len(lines)])]


def check_page(root, page, problems, stale, full_clone):
    path = root / page
    lines = path.read_text().split("\n")
    in_code = [False] * len(lines)
    fence = False
    for i, l in enumerate(lines):
        if l.lstrip().startswith("```"):
            fence = not fence
            in_code[i] = True
        else:
            in_code[i] = fence
    counts = {"tables": 0, "images": 0, "sources": 0}
    for a, b in sections(lines):
        sources, items = [], []
        prev_table = False
        for i in range(a, b + 1):
            l = lines[i]
            if in_code[i]:
                prev_table = False
                continue
            m = SOURCE.match(l)
            if m:
                sources.append((i, m.group(1)))
            table = l.startswith("|")
            if table and not prev_table:
                items.append((i, "table", None))
            prev_table = table
            for img in IMAGE.findall(l):
                items.append((i, "image", img))
        written = [s for s in sources if not s[1].startswith("hand-written")]
        for i, text in sources:
            where = f"{page}:{i + 1}"
            counts["sources"] += 1
            if text.startswith("hand-written"):
                continue
            cmds = COMMAND.findall(text.split(" at commit")[0].split("; committed in")[0])
            if not cmds:
                problems.append(f"{where}: source line names no command in backticks")
            for c in cmds:
                for p in REPO_PATH.findall(c):
                    if not (root / p.rstrip(".,;")).exists() and "*" not in p and "<" not in p:
                        problems.append(f"{where}: the command `{c}` names {p}, which does not exist")
            if "uncommitted changes" in text:
                problems.append(f"{where}: stamped from a tree with uncommitted changes; regenerate "
                                "from a committed tree")
            h = HASH.search(text)
            if not h:
                problems.append(f"{where}: source line without 'at commit HASH' or 'committed in HASH'")
                continue
            if full_clone and git(root, "merge-base", "--is-ancestor", h.group(1), "HEAD") is None:
                problems.append(f"{where}: {h.group(1)} is not a commit in the history of HEAD")
            elif full_clone and stale is not None:
                scripts = {p for c in cmds for p in REPO_PATH.findall(c) if (root / p).is_file()}
                # and the scripts those name (scripts/chapter5.sh runs scripts/chapter5.py)
                for p in list(scripts):
                    for q in re.findall(r"scripts/[\w.-]+", (root / p).read_text(errors="replace")):
                        if (root / q).is_file() and q != "scripts/provenance.py":
                            scripts.add(q)
                scripts = sorted(scripts)
                if scripts:
                    log = git(root, "log", "--format=%h", f"{h.group(1)}..HEAD", "--", *scripts) or ""
                    n = len(log.split()) if log else 0
                    stale.append(f"{where}: {n} later commit(s) changed {', '.join(scripts)}")
        for i, kind, img in items:
            counts[kind + "s"] += 1
            where = f"{page}:{i + 1}"
            if kind == "image":
                if not (path.parent / img).exists():
                    problems.append(f"{where}: image {img} does not exist")
                if not written:
                    problems.append(f"{where}: image {img} has no 'Source:' line with a command in its "
                                    "section")
            elif not sources:
                problems.append(f"{where}: table without a 'Source:' line in its section")
    return counts


def check(root, stale_report):
    root = pathlib.Path(root).resolve()
    shallow = git(root, "rev-parse", "--is-shallow-repository")
    full_clone = shallow == "false"
    problems, stale = [], ([] if stale_report else None)
    totals = {}
    for page in PAGES:
        for k, v in check_page(root, page, problems, stale, full_clone).items():
            totals[k] = totals.get(k, 0) + v
    for p in problems:
        print(p)
    if stale_report:
        print("\n".join(stale) if stale else "no later changes of the generators")
    print(f"provenance: {totals['tables']} tables, {totals['images']} images, {totals['sources']} source "
          f"lines in {', '.join(PAGES)}; {len(problems)} problem(s)"
          + ("" if full_clone else "; commits not checked (not a full git clone)"))
    return 1 if problems else 0


def selftest():
    """check() on small pages in a temporary directory (not a git checkout): a page whose table and
    image have source lines passes; each way of breaking it is reported. Returns 0 if all behave."""
    import tempfile
    good = ("# Page\n\n## A\n\nSource: `scripts/gen.sh --x` committed in abc1234 (2026-01-01).\n\n"
            "| a | b |\n|---|---|\n| 1 | 2 |\n\n![f](figures/f.png)\n\n## B\n\n"
            "Source: hand-written (definitions).\n\n| c |\n|---|\n| 3 |\n\n```\n| not a table |\n```\n")
    broken = {
        "table without a source line": good.replace("Source: hand-written (definitions).\n\n", ""),
        "image without a command": good.replace("Source: `scripts/gen.sh --x` committed in abc1234 (2026-01-01).",
                                                "Source: hand-written (no).") ,
        "missing image": good.replace("figures/f.png", "figures/g.png"),
        "command naming a missing script": good.replace("scripts/gen.sh", "scripts/gone.sh"),
        "no commit": good.replace(" committed in abc1234", ""),
        "uncommitted changes": good.replace("committed in abc1234", "at commit abc1234 with uncommitted changes"),
    }
    failures = 0
    for name, page in [("good", good)] + list(broken.items()):
        with tempfile.TemporaryDirectory() as d:
            root = pathlib.Path(d)
            (root / "docs" / "figures").mkdir(parents=True)
            (root / "scripts").mkdir()
            (root / "scripts" / "gen.sh").write_text("")
            (root / "docs" / "figures" / "f.png").write_bytes(b"")
            for pg in PAGES:
                (root / pg).write_text(page if pg == PAGES[0] else "# Other\n")
            problems = []
            for pg in PAGES:
                check_page(root, pg, problems, None, False)
            ok = (not problems) if name == "good" else bool(problems)
            print(("ok   " if ok else "FAIL ") + f"{name}: {len(problems)} problem(s)")
            failures += not ok
    return 1 if failures else 0


def main(argv):
    root = pathlib.Path(__file__).resolve().parent.parent
    if len(argv) >= 1 and argv[0] == "stamp" and len(argv) > 1:
        print(stamp(argv[1:], root))
        return 0
    if argv[:1] == ["selftest"]:
        return selftest()
    if len(argv) >= 1 and argv[0] == "check":
        rest = [a for a in argv[1:] if a != "--stale"]
        return check(rest[0] if rest else root, "--stale" in argv)
    sys.stderr.write(__doc__)
    return 2


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
