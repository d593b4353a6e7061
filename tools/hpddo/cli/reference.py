"""The command-line reference of the documentation (docs/cli/: an index and a page per subcommand), generated from the parsers
of every subcommand, so an option added to a parser and not to the page fails a test
(test/py/test_docs.py regenerates the page and compares it byte for byte):

    cd tools && ../.venv/bin/python -m hpddo.cli.reference --write      # or --check

A committed page rather than a hook at site build time: it reads on GitHub and in a clone
without building the site, and a changed option shows in the review's diff of the page.
The table is built from the parsers' actions, not from argparse's help text, which wraps
with the terminal's width and changes between Python versions.
"""
from __future__ import annotations

import argparse
import hashlib
import sys
import textwrap

from . import SUBCOMMANDS, parser
from ..schema import ROOT

FOLDER = "docs/cli"
COMMAND = "cd tools && ../.venv/bin/python -m hpddo.cli.reference --write"


def _cell(text: str) -> str:
    """text as one cell of a Markdown table: one line, no column break, no HTML."""
    text = " ".join(str(text).split())
    return text.replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;").replace("|", "\\|")


def _help(action: argparse.Action, prog: str) -> str:
    text = action.help or ""
    if "%" in text:  # argparse expands every help string
        params = dict(vars(action), prog=prog)
        params = {k: (v.__name__ if hasattr(v, "__name__") else v) for k, v in params.items()}
        text = text % params
    return _portable(text)


def _argument(action: argparse.Action) -> str:
    if action.nargs == 0:
        return ""
    if action.choices is not None:
        return "{" + ",".join(map(str, action.choices)) + "}"
    mv = action.metavar if action.metavar is not None else (action.dest.upper() if action.option_strings
                                                            else action.dest)
    mv = " ".join(mv) if isinstance(mv, tuple) else mv
    return {"?": f"[{mv}]", "*": f"[{mv} ...]", "+": f"{mv} [{mv} ...]"}.get(action.nargs, mv)


def _default(action: argparse.Action) -> str:
    d = action.default
    if action.nargs == 0 or d is None or d is argparse.SUPPRESS or d == [] or d == "":
        return ""
    return _portable(",".join(map(str, d)) if isinstance(d, (list, tuple)) else str(d))


def _portable(text: str) -> str:
    """text with the source tree's absolute path made relative to it, as it reads in any clone:
    the page is the same on every machine."""
    from .. import resource_root
    root = str(resource_root().resolve())
    return text.replace(root + "/", "").replace(root, ".")


def section(name: str) -> str:
    """The reference of `hpddo NAME`: what it does, its arguments and options."""
    p = parser(name)
    prog = f"hpddo {name}"
    actions = [a for a in p._actions if a.help is not argparse.SUPPRESS and not isinstance(a, argparse._HelpAction)]
    positionals = [a for a in actions if not a.option_strings]
    usage = " ".join([prog, "[options]"] + [_argument(a) for a in positionals])
    lines = [f"## {prog}", "", _cell(SUBCOMMANDS[name][1]).rstrip(".") + ".", "", "```", usage, "```", ""]
    if p.description:  # as `--help` prints it: the subcommands lay their descriptions out for a terminal
        text = textwrap.dedent(p.description).strip("\n").replace("%%", "%")
        lines += ["```text", *(ln.rstrip() for ln in text.splitlines()), "```", ""]
    lines += ["| argument or option | value | default | what |", "|---|---|---|---|"]
    for a in actions:
        flags = ", ".join(f"`{s}`" for s in a.option_strings) if a.option_strings else f"`{_argument(a)}`"
        value = _argument(a) if a.option_strings else ""
        default = _default(a)
        lines.append(f"| {flags} | {'`' + _cell(value) + '`' if value else ''} | "
                     f"{'`' + _cell(default) + '`' if default else ''} | {_cell(_help(a, prog))} |")
    return "\n".join(lines) + "\n"


def _provenance(body: str) -> str:
    return (f"<!-- GENERATED from the parsers of tools/hpddo/cli/ by `{COMMAND}`; do not edit. "
            f"sha256 {hashlib.sha256(body.encode()).hexdigest()[:16]} of the text below this line. -->\n\n")


def pages() -> dict:
    """{path relative to the repository: text} of the command reference as it should read: an
    index of the subcommands in the order of `hpddo --help`, and a page per subcommand, each with
    a provenance line (the command, the sha256 of its text)."""
    out = {}
    for name in SUBCOMMANDS:
        body = section(name)
        title, rest = body.split("\n", 1)
        out[f"{FOLDER}/{name}.md"] = title.replace("## ", "# ", 1) + "\n\n" + _provenance(rest) + rest.lstrip("\n")
    body = ("Every subcommand of `hpddo` with every argument and option, generated from the command's own "
            "parsers (`hpddo NAME --help` prints the same). The conventions every subcommand shares (one line "
            "and status 1 for a user error, `--quiet`, Ctrl-C) are in "
            "[Architecture](../architecture.md#stopping-and-failing).\n\n"
            "| command | what it does |\n|---|---|\n"
            + "".join(f"| [`hpddo {name}`]({name}.md) | {_cell(SUBCOMMANDS[name][1])} |\n" for name in SUBCOMMANDS))
    out[f"{FOLDER}/index.md"] = "# Command reference\n\n" + _provenance(body) + body
    return out


def stale(root=ROOT) -> list:
    """The pages of the reference that differ from what the parsers give (or are missing), and
    the pages in its folder no subcommand writes."""
    want = pages()
    out = [rel for rel, text in want.items()
           if not (root / rel).exists() or (root / rel).read_text(encoding="utf-8") != text]
    return out + sorted(str(p.relative_to(root)) for p in (root / FOLDER).glob("*.md")
                        if str(p.relative_to(root)) not in want)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python -m hpddo.cli.reference", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    g = ap.add_mutually_exclusive_group(required=True)
    g.add_argument("--write", action="store_true", help=f"write the pages of {FOLDER}/")
    g.add_argument("--check", action="store_true", help=f"exit 1 when a page of {FOLDER}/ is out of date")
    args = ap.parse_args(argv)
    bad = stale()
    if not bad:
        print(f"{FOLDER}/ up to date")
        return 0
    if args.check:
        print(f"out of date (run: {COMMAND}): " + ", ".join(bad), file=sys.stderr)
        return 1
    want = pages()
    (ROOT / FOLDER).mkdir(parents=True, exist_ok=True)
    for rel in bad:
        if rel in want:
            (ROOT / rel).write_text(want[rel], encoding="utf-8")
            print(f"wrote {rel}")
        else:
            print(f"note: {rel} documents no subcommand; remove it", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
